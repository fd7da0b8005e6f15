fn main() {
    println!("{}", snell::provenance::line());
}
