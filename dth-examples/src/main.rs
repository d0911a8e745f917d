//! The `dth` command (placeholder: filled by the scenes issue).

fn main() {
    println!("dth: scenes are not implemented yet");
}
