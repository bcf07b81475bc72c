fn main() {
    println!("wsm: under construction");
}
