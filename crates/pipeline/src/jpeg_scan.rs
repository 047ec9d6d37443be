//! Is a baseline JPEG's scan data complete? A decoder that reaches the end of the data (or a
//! marker, e.g. an end-of-image marker appended to a file cut in half) before the last block
//! fills the rest with grey and reports success: the `image` crate's decoder (zune-jpeg) does so
//! even in its strict mode, and no maintained crate reports it. So this walks the entropy-coded
//! data itself: the Huffman codes of every block (no dequantisation, no inverse DCT), counting
//! the MCUs until the data ends. Baseline and extended sequential Huffman frames (SOF0, SOF1)
//! with all components in one scan or one component; any other frame (progressive,
//! arithmetic-coded, lossless) or a multi-scan sequential frame is not checked (`Ok`).

/// Why the scan data is not complete.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ScanError {
    /// The data ends (a marker or the end of the file) before the last MCU.
    Truncated { decoded: usize, expected: usize },
    /// A code no table holds, a coefficient past the block, or a malformed segment.
    Corrupt(&'static str),
}

impl std::fmt::Display for ScanError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ScanError::Truncated { decoded, expected } => write!(
                f,
                "its image data ends after {decoded} of its {expected} blocks of 8x8 pixels (a file cut short; \
                 the missing part would decode as grey)"
            ),
            ScanError::Corrupt(what) => write!(f, "its image data is corrupt ({what})"),
        }
    }
}

/// One Huffman table in the form of the JPEG standard's decoding procedure (F.2.2.3): per code
/// length the largest code, and where its symbols start; and, for the codes of up to
/// [`FAST_BITS`] bits (nearly all of them), the symbol and length by their first bits.
struct Table {
    maxcode: [i32; 17],
    valptr: [i32; 17],
    mincode: [i32; 17],
    symbols: Vec<u8>,
    /// By the next `FAST_BITS` bits: (symbol, code length), length 0 for a longer code.
    fast: Vec<(u8, u8)>,
}

/// Bits looked up at once.
const FAST_BITS: u32 = 9;

impl Table {
    fn new(counts: &[u8; 16], symbols: &[u8]) -> Self {
        let mut t = Table {
            maxcode: [-1; 17],
            valptr: [0; 17],
            mincode: [0; 17],
            symbols: symbols.to_vec(),
            fast: vec![(0, 0); 1 << FAST_BITS],
        };
        let (mut code, mut k) = (0i32, 0i32);
        for len in 1..=16 {
            let n = counts[len - 1] as i32;
            if n > 0 {
                t.valptr[len] = k;
                t.mincode[len] = code;
                if len as u32 <= FAST_BITS {
                    for (c, &sym) in (code..code + n).zip(symbols.iter().skip(k as usize)) {
                        let shift = FAST_BITS - len as u32;
                        // (a table with more codes than its lengths allow: the rest is corrupt)
                        for e in t.fast.iter_mut().skip((c as usize) << shift).take(1 << shift) {
                            *e = (sym, len as u8);
                        }
                    }
                }
                code += n;
                k += n;
                t.maxcode[len] = code - 1;
            }
            code <<= 1;
        }
        t
    }
}

/// Bits of the entropy-coded data: `0xFF 0x00` is a data byte `0xFF`; any other marker ends
/// the data (restart markers are consumed by [`Bits::restart`]). Whole bytes are loaded into a
/// 64-bit word and codes are matched on the next 16 bits at once (bit by bit, the walk took
/// longer than decoding the image).
struct Bits<'a> {
    data: &'a [u8],
    pos: usize,
    /// The low `n` bits are the next ones.
    acc: u64,
    n: u32,
    /// A marker (or the end of the file) was reached: no more data bits.
    ended: bool,
}

impl Bits<'_> {
    /// Loads bytes until more than 56 bits are held or the data ends.
    fn fill(&mut self) {
        while self.n <= 56 && !self.ended {
            let Some(&b) = self.data.get(self.pos) else {
                self.ended = true;
                break;
            };
            if b == 0xFF {
                if self.data.get(self.pos + 1) != Some(&0x00) {
                    self.ended = true;
                    break;
                }
                self.pos += 2;
            } else {
                self.pos += 1;
            }
            self.acc = (self.acc << 8) | b as u64;
            self.n += 8;
        }
    }

    /// Skips `count` bits; `None` when the data ends first.
    fn bits(&mut self, count: u32) -> Option<()> {
        if self.n < count {
            self.fill();
        }
        self.n = self.n.checked_sub(count)?;
        Some(())
    }

    fn decode(&mut self, t: &Table) -> Result<Option<u8>, ScanError> {
        if self.n < 16 {
            self.fill();
        }
        // the next 16 bits, left-aligned, zeros past the end of the data
        let w = if self.n == 0 { 0 } else { ((self.acc << (64 - self.n)) >> 48) as i32 };
        let (sym, len) = t.fast[(w >> (16 - FAST_BITS)) as usize];
        if len > 0 {
            // (a match on the zeros past the end is a code cut short)
            let Some(n) = self.n.checked_sub(len as u32) else { return Ok(None) };
            self.n = n;
            return Ok(Some(sym));
        }
        for len in FAST_BITS + 1..=16u32 {
            let code = w >> (16 - len);
            if code <= t.maxcode[len as usize] {
                // (a match on the zeros past the end is a code cut short)
                let Some(n) = self.n.checked_sub(len) else { return Ok(None) };
                self.n = n;
                let i = (t.valptr[len as usize] + code - t.mincode[len as usize]) as usize;
                return t.symbols.get(i).copied().map(Some).ok_or(ScanError::Corrupt("a code outside its table"));
            }
        }
        if self.n < 16 {
            return Ok(None);
        }
        Err(ScanError::Corrupt("a code no Huffman table holds"))
    }

    /// Skips to the restart marker expected after `interval` MCUs; false when another marker
    /// (or the end) comes first.
    fn restart(&mut self) -> bool {
        self.n = 0;
        let m = self.data.get(self.pos..self.pos + 2);
        if matches!(m, Some([0xFF, 0xD0..=0xD7])) {
            self.pos += 2;
            self.ended = false;
            true
        } else {
            false
        }
    }
}

fn be16(b: &[u8], i: usize) -> Option<usize> {
    Some(u16::from_be_bytes([*b.get(i)?, *b.get(i + 1)?]) as usize)
}

/// Checks that the first scan of a baseline JPEG holds every MCU of the frame (see the module
/// docs for what is checked).
pub(crate) fn check(bytes: &[u8]) -> Result<(), ScanError> {
    let malformed = ScanError::Corrupt("a malformed segment");
    if bytes.get(..2) != Some(&[0xFF, 0xD8]) {
        return Err(ScanError::Corrupt("no start-of-image marker"));
    }
    let mut dc: [Option<Table>; 4] = Default::default();
    let mut ac: [Option<Table>; 4] = Default::default();
    // per frame component: id, horizontal and vertical sampling
    let mut comps: Vec<(u8, usize, usize)> = Vec::new();
    let (mut width, mut height, mut interval) = (0usize, 0usize, 0usize);
    let mut i = 2;
    loop {
        // markers may be preceded by fill bytes 0xFF
        while bytes.get(i) == Some(&0xFF) && bytes.get(i + 1) == Some(&0xFF) {
            i += 1;
        }
        let (Some(&0xFF), Some(&m)) = (bytes.get(i), bytes.get(i + 1)) else { return Err(malformed) };
        i += 2;
        if m == 0xD9 {
            return Err(ScanError::Corrupt("no scan before the end-of-image marker"));
        }
        if (0xD0..=0xD7).contains(&m) || m == 0x01 {
            continue;
        }
        let len = be16(bytes, i).ok_or(malformed.clone())?;
        let seg = bytes.get(i + 2..i + len).ok_or(malformed.clone())?;
        match m {
            0xC0 | 0xC1 => {
                height = be16(seg, 1).ok_or(malformed.clone())?;
                width = be16(seg, 3).ok_or(malformed.clone())?;
                let n = *seg.get(5).ok_or(malformed.clone())? as usize;
                for k in 0..n {
                    let c = seg.get(6 + 3 * k..9 + 3 * k).ok_or(malformed.clone())?;
                    comps.push((c[0], (c[1] >> 4) as usize, (c[1] & 15) as usize));
                }
                if comps.iter().any(|c| c.1 == 0 || c.2 == 0) || width == 0 || height == 0 {
                    // (a height of 0 is defined later by a DNL marker: not checked)
                    return Ok(());
                }
            }
            // other frames (progressive, lossless, arithmetic): not checked
            0xC2 | 0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => return Ok(()),
            0xC4 => {
                let mut k = 0;
                while k < seg.len() {
                    let tc = seg[k];
                    let counts: [u8; 16] = seg.get(k + 1..k + 17).ok_or(malformed.clone())?.try_into().expect("16");
                    let total: usize = counts.iter().map(|&c| c as usize).sum();
                    let symbols = seg.get(k + 17..k + 17 + total).ok_or(malformed.clone())?;
                    let table = Some(Table::new(&counts, symbols));
                    match (tc >> 4, (tc & 15) as usize) {
                        (0, id @ 0..=3) => dc[id] = table,
                        (1, id @ 0..=3) => ac[id] = table,
                        _ => return Err(malformed),
                    }
                    k += 17 + total;
                }
            }
            0xDD => interval = be16(seg, 0).ok_or(malformed.clone())?,
            0xDA => {
                if comps.is_empty() {
                    return Ok(());
                }
                let n = *seg.first().ok_or(malformed.clone())? as usize;
                // the scan's components: frame index and tables
                let mut scan = Vec::new();
                for k in 0..n {
                    let c = seg.get(1 + 2 * k..3 + 2 * k).ok_or(malformed.clone())?;
                    let f = comps.iter().position(|x| x.0 == c[0]).ok_or(malformed.clone())?;
                    let (d, a) = ((c[1] >> 4) as usize, (c[1] & 15) as usize);
                    let (Some(Some(d)), Some(Some(a))) = (dc.get(d), ac.get(a)) else {
                        return Err(ScanError::Corrupt("a scan without its Huffman tables"));
                    };
                    scan.push((f, d, a));
                }
                let (hmax, vmax) = comps.iter().fold((1, 1), |(h, v), c| (h.max(c.1), v.max(c.2)));
                // the scan component of each block of an MCU, and the MCUs: all components
                // interleaved, or one component alone
                let (per_mcu, expected): (Vec<usize>, usize) = if n == comps.len() && n > 1 {
                    let blocks =
                        scan.iter().enumerate().flat_map(|(s, x)| std::iter::repeat_n(s, comps[x.0].1 * comps[x.0].2));
                    (blocks.collect(), width.div_ceil(8 * hmax) * height.div_ceil(8 * vmax))
                } else if n == 1 {
                    let c = comps[scan[0].0];
                    let (cw, ch) = ((width * c.1).div_ceil(hmax), (height * c.2).div_ceil(vmax));
                    (vec![0], cw.div_ceil(8) * ch.div_ceil(8))
                } else {
                    return Ok(());
                };
                let data = &bytes[i + len..];
                let mut bits = Bits { data, pos: 0, acc: 0, n: 0, ended: false };
                for mcu in 0..expected {
                    if interval > 0 && mcu > 0 && mcu % interval == 0 && !bits.restart() {
                        return Err(ScanError::Truncated { decoded: mcu, expected });
                    }
                    for &s in &per_mcu {
                        let (_, dct, act) = &scan[s];
                        let truncated = Err(ScanError::Truncated { decoded: mcu, expected });
                        let Some(size) = bits.decode(dct)? else { return truncated };
                        if size > 11 {
                            return Err(ScanError::Corrupt("a DC difference of more than 11 bits"));
                        }
                        if bits.bits(size as u32).is_none() {
                            return truncated;
                        }
                        let mut k = 1;
                        while k < 64 {
                            let Some(rs) = bits.decode(act)? else { return truncated };
                            let (r, s) = ((rs >> 4) as usize, rs & 15);
                            if s == 0 {
                                if r != 15 {
                                    break;
                                }
                                k += 16;
                                continue;
                            }
                            k += r;
                            if k > 63 {
                                return Err(ScanError::Corrupt("a coefficient past the end of its block"));
                            }
                            if bits.bits(s as u32).is_none() {
                                return truncated;
                            }
                            k += 1;
                        }
                    }
                }
                return Ok(());
            }
            _ => {}
        }
        i += len;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode(img: &image::DynamicImage, quality: u8) -> Vec<u8> {
        let mut bytes = Vec::new();
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, quality).encode_image(img).unwrap();
        bytes
    }

    fn textured(w: u32, h: u32) -> image::RgbImage {
        image::RgbImage::from_fn(w, h, |x, y| {
            let v = (x * 37 + y * 91 + (x * y) % 17) as u8;
            image::Rgb([v, v.wrapping_mul(3), (x ^ y) as u8])
        })
    }

    /// Whole files pass; the same files cut anywhere in their image data, with an end-of-image
    /// marker appended, are refused as truncated (colour 4:2:0 and grey, sizes not a multiple of
    /// the MCU).
    #[test]
    fn a_file_cut_short_is_found_whatever_the_cut() {
        for img in [
            image::DynamicImage::ImageRgb8(textured(131, 77)),
            image::DynamicImage::ImageLuma8(image::DynamicImage::ImageRgb8(textured(97, 64)).to_luma8()),
        ] {
            for quality in [50, 95] {
                let bytes = encode(&img, quality);
                assert_eq!(check(&bytes), Ok(()), "whole file");
                let sos = bytes.windows(2).position(|w| w == [0xFF, 0xDA]).unwrap();
                let end = bytes.len() - 2;
                for cut in [sos + 20, (sos + end) / 2, end - 40, end - 8] {
                    let mut t = bytes[..cut].to_vec();
                    t.extend_from_slice(&[0xFF, 0xD9]);
                    assert!(
                        matches!(check(&t), Err(ScanError::Truncated { .. })),
                        "cut at {cut} of {end}: {:?}",
                        check(&t)
                    );
                    // and without the marker
                    assert!(matches!(check(&bytes[..cut]), Err(ScanError::Truncated { .. })));
                }
            }
        }
    }

    fn cuts(bytes: &[u8]) -> Vec<Vec<u8>> {
        let sos = bytes.windows(2).position(|w| w == [0xFF, 0xDA]).unwrap();
        let end = bytes.len() - 2;
        [sos + 30, (sos + end) / 2, end - 16]
            .into_iter()
            .map(|cut| {
                let mut t = bytes[..cut].to_vec();
                t.extend_from_slice(&[0xFF, 0xD9]);
                t
            })
            .collect()
    }

    /// Files OpenCV wrote (`tests/data/opencv-jpeg/`, its script: 4:2:0 with restart markers,
    /// 4:4:4, grey): whole they pass, cut short with an end marker they are refused; the
    /// progressive one is not checked (passes whole and cut: the end-marker check is all it gets).
    #[test]
    fn files_opencv_wrote_pass_whole_and_are_refused_cut() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/opencv-jpeg");
        for name in ["rst_420.jpg", "colour_444.jpg", "grey.jpg", "progressive.jpg"] {
            let bytes = std::fs::read(dir.join(name)).unwrap();
            assert_eq!(check(&bytes), Ok(()), "{name}");
            for t in cuts(&bytes) {
                let r = check(&t);
                if name == "progressive.jpg" {
                    assert_eq!(r, Ok(()), "{name}: not checked");
                } else {
                    assert!(matches!(r, Err(ScanError::Truncated { .. })), "{name}: {r:?}");
                }
            }
        }
    }

    /// The real photographs of `../shared` (OpenCV's stereo chessboard set): every one passes
    /// whole and is refused cut short with an end marker.
    #[test]
    fn real_photographs_pass_whole_and_are_refused_cut() {
        let dir =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/opencv-stereo-chessboard");
        let Ok(entries) = std::fs::read_dir(&dir) else {
            println!("skipped: {} not found", dir.display());
            return;
        };
        let mut n = 0;
        for e in entries.flatten().filter(|e| e.path().extension().is_some_and(|x| x == "jpg")) {
            let bytes = std::fs::read(e.path()).unwrap();
            assert_eq!(check(&bytes), Ok(()), "{}", e.path().display());
            for t in cuts(&bytes) {
                assert!(matches!(check(&t), Err(ScanError::Truncated { .. })), "{}", e.path().display());
            }
            n += 1;
        }
        println!("{n} real JPEGs checked");
        assert!(n > 0);
    }
}
