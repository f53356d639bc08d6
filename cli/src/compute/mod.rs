//! The desktop's computing kit under every application module: both cores for passes over many
//! poses ([`parallel`]), the library LM's storage sized from the problem on the heap
//! ([`vec_lm`]) with its vector kernels ([`rows_avx2`], [`batch_avx2`]), models' effect values
//! on the heap ([`host_values`]), large lists on huge pages ([`huge_pages`]), freed blocks kept
//! for reuse ([`heap`]), dense
//! factorisations arranged as matrix products ([`dense`]), band factors ([`banded`]) and
//! point-set registration ([`registration`]).

pub mod banded;
#[cfg(target_arch = "x86_64")]
pub mod batch_avx2;
pub mod dense;
pub mod heap;
pub mod host_values;
pub mod huge_pages;
pub mod parallel;
pub mod registration;
#[cfg(target_arch = "x86_64")]
pub mod rows_avx2;
pub mod tool_start;
pub mod vec_lm;
