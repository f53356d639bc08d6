//! The command line's progress: a spinner with the stage and the time spent.

/// The command line's [`crate::Tell`]: each line on stderr at once, and the stage in a spinner
/// with the time spent, `{command} {spinner} {stage} {elapsed}` (drawn only when stderr is a
/// terminal, as PSO's and `study`'s bars), from the first stage until it is dropped.
pub(crate) struct Spinner {
    command: &'static str,
    bar: Option<indicatif::ProgressBar>,
}

impl Spinner {
    pub(crate) fn new(command: &'static str) -> Self {
        Self { command, bar: None }
    }
}

impl crate::Tell for Spinner {
    fn line(&mut self, text: &str) {
        eprintln!("{text}");
    }
    fn stage(&mut self, what: &str) {
        let command = self.command;
        let bar = self.bar.get_or_insert_with(|| {
            let bar = indicatif::ProgressBar::new_spinner();
            bar.set_style(
                indicatif::ProgressStyle::with_template(&format!(
                    "{command} {{spinner}} {{msg}} {{elapsed}}"
                ))
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            bar.enable_steady_tick(std::time::Duration::from_millis(120));
            bar
        });
        bar.set_message(what.to_string());
    }
}

impl Drop for Spinner {
    fn drop(&mut self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
