//! The `kinecal` command line built inside this package, so that its tests can run it
//! (`CARGO_BIN_EXE_<name>` names only a package's own binaries). Same code as `kinecal-cli`'s
//! `kinecal`: both are `kinecal_cli::commands::main`.

fn main() {
    kinecal_cli::commands::main()
}
