//! Stage 1: measurement records streamed in over a UART FIFO into the CSV reader.

use super::checks::Checks;
use super::{fail, fail_fmt};
use crate::bench::Counter;
use crate::reference as host;
use crate::scenario::{ID_POSES, N, VAL_POSES};
use cortex_m_semihosting::hprintln;
use heapless::Vec;
use kinecal::io::csv::CsvReader;
use kinecal::Measurement;

/// The measurement file, as the host generated it (`src/generate.rs`).
pub(super) static CSV: &[u8] = include_bytes!("../../data/measurements.csv");

/// A UART receive FIFO: at most 16 bytes per read, as the hardware hands them over.
pub(super) struct Uart {
    rx: &'static [u8],
}

impl embedded_io::ErrorType for Uart {
    type Error = core::convert::Infallible;
}

impl embedded_io::Read for Uart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(16).min(self.rx.len());
        buf[..n].copy_from_slice(&self.rx[..n]);
        self.rx = &self.rx[n..];
        Ok(n)
    }
}

/// Stage 1: records in over the UART, split by the carried `set` column.
#[inline(never)]
pub(super) fn stream(
    counter: &mut Counter,
    checks: &mut Checks,
    id: &mut Vec<Measurement<f32, N>, ID_POSES>,
    val: &mut Vec<Measurement<f32, N>, VAL_POSES>,
) {
    let ((sums, errors), insns) = counter.insns_of(|| {
        let mut sums = [0.0f64; 2];
        let mut errors = 0u32;
        let mut reader = match CsvReader::<Uart, N, 128, 4>::new(Uart { rx: CSV }) {
            Ok(r) => r,
            Err(e) => fail_fmt(format_args!(
                "CSV header: {} at line {}",
                e.kind.describe(),
                e.line
            )),
        };
        let (set, temp) = match (reader.extra_index("set"), reader.extra_index("temp_c")) {
            (Some(s), Some(t)) => (s, t),
            _ => fail("CSV lacks the set/temp_c columns"),
        };
        while let Some(rec) = reader.next_record() {
            match rec {
                Ok(r) => {
                    sums[0] += r.q_deg.iter().sum::<f64>() + r.xyz_mm.iter().sum::<f64>();
                    sums[1] += r.extra[temp];
                    let full = if r.extra[set] == 0.0 {
                        id.push(r.measurement()).is_err()
                    } else {
                        val.push(r.measurement()).is_err()
                    };
                    errors += u32::from(full);
                }
                Err(e) => {
                    hprintln!(
                        "CSV line {} column {}: {}",
                        e.line,
                        e.column,
                        e.kind.describe()
                    );
                    errors += 1;
                }
            }
        }
        (sums, errors)
    });
    hprintln!(
        "stream: {} + {} records over the UART in {} instructions",
        id.len(),
        val.len(),
        insns
    );
    checks.check(
        "csv.records",
        id.len() == ID_POSES && val.len() == VAL_POSES && errors == 0,
        format_args!(
            "{} identification + {} held-out poses, {} errors",
            id.len(),
            val.len(),
            errors
        ),
    );
    checks.close("csv.sum", sums[0], host::CSV_SUMS[0], 1e-6);
    checks.close("csv.temp_sum", sums[1], host::CSV_SUMS[1], 1e-9);
}
