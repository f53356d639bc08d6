//! `kinecal`: robot calibration from the command line (interfaces.md §4).

fn main() {
    kinecal_cli::commands::main()
}
