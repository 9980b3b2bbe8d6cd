//! Scratch.
fn main() {
    let lut = cdrf_core::lut_file::read_lut(std::env::args().nth(1).unwrap()).unwrap();
    for k in [0.02f32, 0.05, 0.1, 0.2] {
        for t in [0.0f32, 10.0, 20.0, 30.0, 60.0] {
            let row: Vec<String> = [0.0f32, 30.0, 60.0, 80.0]
                .iter()
                .map(|p| {
                    let g = lut
                        .view_correction()
                        .sample(k, t.to_radians(), p.to_radians());
                    format!("{:.2}/{:.2}/{:.2}", g.x, g.y, g.z)
                })
                .collect();
            println!("κ {k} θ {t}: g(φ=0,30,60,80) {row:?}");
        }
    }
}
