fn main() {
    println!("tonegate");
}
