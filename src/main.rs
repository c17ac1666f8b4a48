fn main() {
    fdem::cli::main()
}
