//! **Frames from sweeps**: 3-D circle fits and the circle-point method (joint axes, base frame,
//! tool distances from single-joint sweeps; Gao et al. 2018 §2.2).

pub mod circle;
pub mod circle_point;
