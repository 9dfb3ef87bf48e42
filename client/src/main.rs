fn main() -> std::process::ExitCode {
    cosim_client::cli::main()
}
