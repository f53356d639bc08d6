//! (next commit)

/// Room for identified parameters in a `kc_lm` (the firmware's 24-parameter MDH set).
pub const KC_LM_MAX_PARAMS: usize = 24;
