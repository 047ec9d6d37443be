//! Prints the chessboard corners of the images given on the command line, one line per image:
//! `path ms x0 y0 x1 y1 ...` (or `path ms none`), coordinates printed to full precision (the
//! shortest decimal that reads back as the same `f64`), for comparison with other tools and
//! between versions.
//! Usage: `cargo run --release -p corner-detection --example dump_corners -- [subpix|saddle] COLSxROWS IMAGES...`

use parallax_corner_detection::{ChessboardConfig, CornerRefinement, detect_chessboard};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        eprintln!("usage: dump_corners subpix|saddle COLSxROWS IMAGES...");
        std::process::exit(2);
    }
    let refinement = match args[0].as_str() {
        "saddle" => CornerRefinement::Saddle,
        "none" => CornerRefinement::None,
        _ => CornerRefinement::SubPix,
    };
    let (c, r) = args[1].split_once('x').expect("COLSxROWS");
    let (cols, rows): (usize, usize) = (c.parse().expect("cols"), r.parse().expect("rows"));
    let cfg = ChessboardConfig { refinement, ..Default::default() };
    for path in &args[2..] {
        let img = match image::open(path) {
            Ok(i) => i.into_luma8(),
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let t0 = std::time::Instant::now();
        let found = detect_chessboard(&img, cols, rows, &cfg);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        match found {
            Ok(Some(d)) => {
                let g = d.grid;
                eprintln!("{path}: pyramid level {}, {} candidates", d.pyramid_level, d.candidates);
                let coords: Vec<String> = g.corners.iter().map(|p| format!("{} {}", p.x, p.y)).collect();
                println!("{path} {ms:.3} {}", coords.join(" "));
            }
            Ok(None) => println!("{path} {ms:.3} none"),
            Err(e) => eprintln!("{path}: {e}"),
        }
    }
}
