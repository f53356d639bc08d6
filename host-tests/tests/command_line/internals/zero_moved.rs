//! `kinecal_cli::calibration::zero_moved` (cli/src/calibration/zero_moved.rs): what its
//! verdict clause says the data cannot tell from a moved zero.

use kinecal_cli::calibration::zero_moved::ZeroMoved;

/// Joint `joint` moved by `shift_deg`, its readings spanning 0.5° around `mean_reading_deg`.
fn moved(joint: usize, shift_deg: f64, mean_reading_deg: f64, last_joint: bool) -> ZeroMoved {
    ZeroMoved {
        joint,
        shift_deg,
        rms_mm: 40.0,
        freed_rms_mm: 0.03,
        mean_reading_deg,
        reading_span_deg: 0.5,
        last_joint,
    }
}

#[test]
fn look_alikes_are_named_beside_the_zero() {
    let plain = moved(3, 5.0, 60.0, false).clause("base+tool", "M.toml", "D.csv");
    assert!(
        plain.starts_with("joint 3's zero moved by +5.00°"),
        "{plain}"
    );
    assert!(!plain.contains("look the same"), "{plain}");
    assert!(
        plain.contains("--robot M.toml --data D.csv --only base,tool,theta3 --out NEW.toml"),
        "{plain}"
    );
    // A joint that averages −2.6° read with its sign flipped shifts by about +5.2°.
    let flip = moved(3, 5.0, -2.6, false).clause("base", "M.toml", "D.csv");
    assert!(flip.contains("its readings' sign flipped"), "{flip}");
    assert!(flip.contains("--only base,theta3 "), "{flip}");
    // ... not when the joint moves over the session: a flipped sign would not look constant.
    let wide = ZeroMoved {
        reading_span_deg: 90.0,
        ..moved(3, 5.0, -2.6, false)
    };
    let wide = wide.clause("base", "M.toml", "D.csv");
    assert!(!wide.contains("sign flipped"), "{wide}");
    // Nothing registered: joint 1's zero is a turned base; the last joint's a turned probe
    // unless the tool is registered.
    let base = moved(1, -2.0, 40.0, false).clause("none", "M.toml", "D.csv");
    assert!(
        base.contains("the base turned about joint 1's axis"),
        "{base}"
    );
    assert!(base.contains("--only theta1 "), "{base}");
    let probe = moved(6, 3.0, 90.0, true).clause("base", "M.toml", "D.csv");
    assert!(
        probe.contains("the probe turned about the flange axis"),
        "{probe}"
    );
    let probe_registered = moved(6, 3.0, 90.0, true).clause("base+tool", "M.toml", "D.csv");
    assert!(
        !probe_registered.contains("look the same"),
        "{probe_registered}"
    );
    // Beyond 10° identify refuses the change: only a re-mastering is suggested.
    let far = moved(2, -45.0, 30.0, false).clause("base+tool", "M.toml", "D.csv");
    assert!(
        far.contains("zero moved by -45.0°") && !far.contains("kinecal identify"),
        "{far}"
    );
}
