//! The `tonegate` binary: everything lives in the library's `cli` module.

fn main() -> std::process::ExitCode {
    tonegate::cli::main()
}
