//! **Measurement planning** (Jost et al. 2017): the information matrix and the covariances it
//! predicts, observability indices and design criteria, the measurement cell and its collision,
//! floor, beam and incidence checks, candidate poses, the selection of a design and the online
//! next-best-pose stepper.

pub mod capsule;
pub mod cell;
pub mod information;
pub mod observability;
pub mod online_design;
pub mod pose_pool;
pub mod selection;
