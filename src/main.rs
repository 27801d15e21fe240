//! The `onomato` binary: everything lives in the library; see `onomato::cli`.

fn main() -> std::process::ExitCode {
    onomato::cli::main()
}
