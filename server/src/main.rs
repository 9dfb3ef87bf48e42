fn main() -> std::process::ExitCode {
    cosim_server::cli::main()
}
