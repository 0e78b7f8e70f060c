//! `host`: the command-line front end of the nlmode tool.
mod plot;
mod results;
mod scenario;

fn main() {
    println!("host: under construction");
}
