//! BPNN-PSO (the paper's §3.2): a swarm that starts where a network trained on the previous
//! identification of the same robot predicts the particles will end.
//!
//! ## Our reading of the paper
//!
//! - **Training data** (§3.2.1, "the input … the locations of particle swarms initialized in the
//!   second step of PSO … the optimal value … used as the output", "the training data … are 200
//!   groups"): one pair per particle of a *finished* PSO run. We pair each particle's drawn
//!   initial position with **that particle's final personal best** ([`train`]). The paper's
//!   wording also allows the final *global* best as every target, but then all 200 targets are
//!   the same vector, the network degenerates to a constant, and every predicted particle lands
//!   on one point: a swarm with no spread and no velocity never moves. Personal bests give 200
//!   distinct targets whose spread is the previous run's own uncertainty (wide along the
//!   directions the data determine poorly, narrow along the others), and a trained net maps
//!   the new random draws to a cloud of that shape.
//! - **Use** (§3.2.2, "uses the trained neural networks to predict the location of particles
//!   before updating the particles"): in the next identification the swarm is drawn as usual,
//!   each particle's draw is fed to the network, and the particle **starts at the prediction**
//!   (clamped into the box, at rest; [`seed`]). From there it is the unchanged PSO with the same
//!   objective, coefficients, bounds and termination, every particle evaluated normally, so the
//!   comparison with plain PSO is like for like. The drawn positions stay in
//!   [`Pso::initial_positions`], so a BPNN-PSO run can itself train the next network.
//! - **Network**: [`Bpnn`] with `D` inputs and outputs and the paper's hidden-size rule
//!   ([`crate::identify::bpnn::hidden_size`], 12 neurons for 24 parameters), trained [`DEFAULT_EPOCHS`]
//!   epochs (the loss stops falling well before).
//!
//! ## What it buys, measured
//!
//! ER20-C10 stand-in, 24 MDH parameters, 50 poses, 10 µm noise, the defaults of
//! [`crate::identify::pso::PsoConfig::calibration`] (1,000 iterations at most). A factory PSO run trains the
//! net; after the robot's errors drift, plain PSO and BPNN-PSO identify it again from the same
//! swarm seeds. Ratio = iterations BPNN-PSO needs to reach plain PSO's final fitness ÷ iterations
//! PSO needed to first reach it; 3 factory runs × 8 follow-up seeds per row:
//!
//! | drift of alpha/theta, a/d since training         | Σ BPNN-PSO ÷ Σ PSO | median      | worst run |
//! |--------------------------------------------------|--------------------|-------------|-----------|
//! | none (new measurements only)                     | 0.04–0.18          | 0.00–0.15   | 0.54      |
//! | ≤ 0.002°, ≤ 0.01 mm (≈ 0.07 mm RMS at the tool)  | 0.14–0.15          | 0.08–0.11   | 0.46      |
//! | ≤ 0.005°, ≤ 0.025 mm                             | 0.23–0.37          | 0.15–0.35   | 0.83      |
//! | ≤ 0.01°, ≤ 0.05 mm                               | 0.30–0.48          | 0.26–0.37   | 1.00      |
//! | ≤ 0.02°, ≤ 0.1 mm (≈ 0.7 mm RMS at the tool)     | 0.49–0.57          | 0.47–0.54   | 0.99      |
//!
//! So the paper's "a quarter of the iterations" holds on average for a small drift (up to ≈ 1 %
//! of the factory errors) and fades to 2× for a drift of 10 %. The network knows the previous
//! solution, not the new data: BPNN-PSO skips PSO's global phase and starts refining near the old
//! solution. It cannot skip the late phase: with the paper's `w = 0.9`, `c1 + c2 = 1.75` (close to
//! PSO's second-order stability limit of ≈ 1.82 for that `w`) the swarm's spread shrinks by well
//! under 1 % per iteration wherever it starts; even a swarm placed around the follow-up's own
//! optimum needs hundreds of iterations to match a fully converged PSO. Single runs scatter
//! widely because plain PSO's own final fitness does (0.012–0.09 mm² over seeds). Starting the
//! predicted particles with random velocities, or predicting only part of the swarm, was no
//! better. The paper's own BPNN-PSO (71 iterations) also stopped at a higher fitness than its
//! PSO (404 iterations).

use crate::identify::bpnn::{Bpnn, BpnnError};
use crate::identify::pso::{Pso, PsoError};
use crate::Real;

/// Epochs of back-propagation in [`train`] by default.
pub const DEFAULT_EPOCHS: u32 = 300;

/// The network that seeds BPNN-PSO's swarm: the paper's 24 MDH errors in, the predicted ones
/// out (24 → 12 → 24).
pub type MdhSeedNet<T> = Bpnn<
    T,
    24,
    { crate::identify::bpnn::hidden_size(24, 24, crate::identify::bpnn::DEFAULT_A) },
    24,
>;

/// Why BPNN-PSO could not train or seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BpnnPsoError {
    /// The PSO run used for training has not finished.
    NotFinished,
    /// The network refused (see [`BpnnError`]).
    Net(BpnnError),
    /// The swarm refused (already evaluated: seed a fresh or restarted swarm).
    Swarm(PsoError),
}

/// Trains `net` on a finished run: each particle's drawn initial position → its final personal
/// best. Sets the net's normalisation ranges from these pairs, then runs `epochs` epochs;
/// returns the last epoch's loss (mean squared error in normalised units).
pub fn train<
    T: Real,
    const SWARM: usize,
    const D: usize,
    const HIDDEN: usize,
    const HISTORY_LEN: usize,
>(
    net: &mut Bpnn<T, D, HIDDEN, D>,
    run: &Pso<T, SWARM, D, HISTORY_LEN>,
    epochs: u32,
) -> Result<T, BpnnPsoError> {
    if !run.is_finished() {
        return Err(BpnnPsoError::NotFinished);
    }
    let inputs = run.initial_positions();
    let targets = run.personal_bests();
    net.fit_ranges(inputs, targets).map_err(BpnnPsoError::Net)?;
    let mut loss = net.loss(inputs, targets).map_err(BpnnPsoError::Net)?;
    for _ in 0..epochs {
        loss = net
            .train_epoch(inputs, targets)
            .map_err(BpnnPsoError::Net)?;
    }
    Ok(loss)
}

/// Places every particle of a fresh swarm at the network's prediction for its drawn position,
/// at rest. Call after [`Pso::new`] or [`Pso::restart`] and before the first [`Pso::step`].
/// On error the swarm is unchanged.
pub fn seed<
    T: Real,
    const SWARM: usize,
    const D: usize,
    const HIDDEN: usize,
    const HISTORY_LEN: usize,
>(
    swarm: &mut Pso<T, SWARM, D, HISTORY_LEN>,
    net: &Bpnn<T, D, HIDDEN, D>,
) -> Result<(), BpnnPsoError> {
    if swarm.progress().evaluations != 0 {
        return Err(BpnnPsoError::Swarm(PsoError::Start));
    }
    // Check every prediction before moving any particle (predicting twice is cheap).
    if !swarm
        .initial_positions()
        .iter()
        .all(|x| net.forward(x).iter().all(|v| v.finite()))
    {
        return Err(BpnnPsoError::Net(BpnnError::NonFinite));
    }
    let rest = [T::zero(); D];
    for i in 0..SWARM {
        let Some(x) = swarm.initial_positions().get(i).copied() else {
            break;
        };
        let p = net.forward(&x);
        swarm.set_start(i, &p, &rest).map_err(BpnnPsoError::Swarm)?;
    }
    Ok(())
}
