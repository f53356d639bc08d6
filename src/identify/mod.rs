//! **Identification**: steppers that do a bounded slice of work per `step()` and can be
//! snapshotted and resumed: streaming Levenberg–Marquardt with identifiability analysis (its
//! storage, its optional penalty (prior) on the parameters and its passes over the data, all
//! under [`lm`]), the objective of the global searches, particle
//! swarm optimisation, the back-propagation network and BPNN-PSO (Gao et al. 2018).

pub mod bpnn;
pub mod bpnn_pso;
pub mod fitness;
pub mod lm;
pub mod pso;
