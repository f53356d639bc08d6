//! `kinecal`: robot calibration from the command line (docs/formats.md, docs/walkthrough.md).

fn main() {
    kinecal_cli::commands::main()
}
