//! The `tonegate` binary: parses the command line (`cli`) and calls the
//! library; the exit code comes from the outcome, or from the error's kind.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
