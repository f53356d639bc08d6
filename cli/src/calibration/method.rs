//! The identification methods `kinecal identify` offers.

/// Identification method.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Levenberg–Marquardt from the nominal model.
    Lm,
    /// Particle swarm over the 24 MDH deltas (Gao et al. 2018 §3.1).
    Pso,
    /// PSO seeded by a BP network trained on a previous PSO run of the same robot (§3.2).
    #[value(name = "bpnn-pso")]
    BpnnPso,
    /// Global PSO search, then an LM polish of the full parameter set.
    #[value(name = "pso+lm")]
    PsoLm,
}

impl Method {
    /// The method's name on the command line and in the JSON report.
    pub fn id(self) -> &'static str {
        match self {
            Method::Lm => "lm",
            Method::Pso => "pso",
            Method::BpnnPso => "bpnn-pso",
            Method::PsoLm => "pso+lm",
        }
    }
}
