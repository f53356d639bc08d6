//! **Model**: the constant robot description (Pinocchio's `Model`): frames, MDH rows with tilt,
//! the non-geometric joint corrections, joint couplings and the named parameters identification
//! changes. Per-evaluation scratch lives in [`crate::forward`].

pub mod coupling;
pub mod effects;
pub mod frame;
pub mod param;
pub mod robot;
