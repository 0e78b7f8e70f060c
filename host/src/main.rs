fn main() {
    println!("host: under construction");
}
