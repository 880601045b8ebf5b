//! Film accumulation: per-pixel mean and variance against a direct computation, and merge
//! determinism across thread counts.
use brume::film::{tiles, Film, PixelStats, TileBuffer, TileRect};

/// An RGB sample with full coverage.
fn opaque(s: [f32; 3]) -> [f32; 4] {
    [s[0], s[1], s[2], 1.0]
}

/// SplitMix64 (Steele et al. 2014): a tiny, fixed-seed source of test samples.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Two-pass mean and unbiased variance in f64: the textbook definition.
fn direct(samples: &[[f32; 3]]) -> ([f64; 3], [f64; 3]) {
    let n = samples.len() as f64;
    let mut mean = [0.0; 3];
    let mut var = [0.0; 3];
    for c in 0..3 {
        mean[c] = samples.iter().map(|s| s[c] as f64).sum::<f64>() / n;
        var[c] = samples
            .iter()
            .map(|s| (s[c] as f64 - mean[c]).powi(2))
            .sum::<f64>()
            / (n - 1.0);
    }
    (mean, var)
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
}

#[test]
fn mean_and_variance_match_a_direct_computation() {
    let mut rng = Rng(1);
    // Heavy-tailed radiance-like samples, and a large mean with tiny noise (where raw sums of
    // squares would cancel catastrophically).
    let cases: Vec<Vec<[f32; 3]>> = vec![
        (0..1000)
            .map(|_| {
                [0, 1, 2].map(|c| (1.0 / (rng.uniform() + 1e-3) - 1.0) as f32 * (c + 1) as f32)
            })
            .collect(),
        (0..500)
            .map(|_| {
                [
                    1.0e3 + 1e-2 * rng.uniform() as f32,
                    7.0,
                    -(rng.uniform() as f32),
                ]
            })
            .collect(),
        vec![[0.25, 0.5, 1.0]; 2],
    ];
    for samples in cases {
        let mut film = Film::new(1, 1);
        for s in &samples {
            film.add_sample(0, 0, opaque(*s));
        }
        let (mean, var) = direct(&samples);
        let n = samples.len() as f64;
        let got_mean = film.mean(0, 0);
        let got_var = film.variance_of_mean(0, 0);
        let stats = film.pixel(0, 0);
        assert_eq!(film.sample_count(0, 0), samples.len() as u32);
        for c in 0..3 {
            assert!(
                close(stats.mean[c], mean[c], 1e-12),
                "mean {c}: {} vs {}",
                stats.mean[c],
                mean[c]
            );
            assert!(close(stats.sample_variance()[c], var[c], 1e-9), "var {c}");
            assert_eq!(got_mean[c], mean[c] as f32);
            assert!(
                close(got_var[c] as f64, var[c] / n, 1e-6),
                "var of mean {c}"
            );
        }
    }
}

#[test]
fn constant_samples_have_exactly_zero_variance() {
    let mut film = Film::new(1, 1);
    for _ in 0..1000 {
        film.add_sample(0, 0, [0.1, 3.7, 1e6, 1.0]);
    }
    assert_eq!(film.variance_of_mean(0, 0), [0.0; 3]);
    assert_eq!(film.mean(0, 0), [0.1, 3.7, 1e6]);
}

#[test]
fn empty_and_single_sample_pixels() {
    let mut film = Film::new(2, 1);
    assert_eq!(film.mean(0, 0), [0.0; 3]);
    assert_eq!(film.variance_of_mean(0, 0), [0.0; 3]);
    assert_eq!(film.sample_count(0, 0), 0);
    film.add_sample(1, 0, [2.0, 3.0, 4.0, 1.0]);
    assert_eq!(film.mean(1, 0), [2.0, 3.0, 4.0]);
    assert_eq!(film.variance_of_mean(1, 0), [0.0; 3]);
    assert_eq!(film.sample_count(1, 0), 1);
}

#[test]
fn merging_splits_matches_the_direct_computation() {
    // Chan's merge of uneven parts must agree with one long Welford run and the direct formula.
    let mut rng = Rng(2);
    let samples: Vec<[f32; 3]> = (0..997)
        .map(|_| [rng.uniform() as f32, (rng.uniform() * 100.0) as f32, 5.0])
        .collect();
    let (mean, var) = direct(&samples);
    let mut merged = PixelStats::default();
    for chunk in samples.chunks(131) {
        let mut part = PixelStats::default();
        chunk.iter().for_each(|s| part.add(opaque(*s)));
        merged.merge(&part);
    }
    merged.merge(&PixelStats::default());
    assert_eq!(merged.count, 997);
    for c in 0..3 {
        assert!(close(merged.mean[c], mean[c], 1e-12));
        assert!(close(merged.sample_variance()[c], var[c], 1e-9) || var[c] == 0.0);
    }
    assert_eq!(merged.sample_variance()[2], 0.0);
}

#[test]
fn tiles_cover_the_image_once_in_a_fixed_order() {
    for (w, h, t) in [(37, 23, 8), (16, 16, 16), (1, 1, 64), (65, 3, 4)] {
        let ts = tiles(w, h, t);
        let mut covered = vec![0u8; (w * h) as usize];
        for (i, r) in ts.iter().enumerate() {
            assert_eq!(r.index as usize, i);
            assert!(r.width() >= 1 && r.width() <= t && r.height() >= 1 && r.height() <= t);
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    covered[(y * w + x) as usize] += 1;
                }
            }
        }
        assert!(covered.iter().all(|&c| c == 1), "{w}x{h} tile {t}");
        // Row-major over tiles.
        assert!(ts
            .windows(2)
            .all(|p| (p[0].y0, p[0].x0) < (p[1].y0, p[1].x0)));
    }
    assert!(tiles(0, 10, 4).is_empty());
}

/// Renders one tile of a fake image: the samples depend only on (pass, pixel, sample).
fn render_tile(rect: TileRect, pass: u32) -> TileBuffer {
    let mut buf = TileBuffer::for_pass(rect, pass);
    for y in rect.y0..rect.y1 {
        for x in rect.x0..rect.x1 {
            let mut rng = Rng(((pass as u64) << 40) ^ ((y as u64) << 20) ^ x as u64);
            for _ in 0..(1 + (x + y) % 5) {
                let u = rng.uniform();
                buf.add_sample(
                    x,
                    y,
                    [
                        (1.0 / (u + 0.01)) as f32,
                        u as f32,
                        (x as f64 * u) as f32,
                        u as f32,
                    ],
                );
            }
        }
    }
    buf
}

/// Renders every tile of three passes with `threads` threads, each thread taking tiles
/// round-robin and handing back buffers in whatever order it finishes; merges in tile order.
fn render(threads: usize, w: u32, h: u32) -> Film {
    let rects = tiles(w, h, 8);
    let work: Vec<(TileRect, u32)> = (0..3)
        .flat_map(|pass| rects.iter().map(move |r| (*r, pass)))
        .collect();
    let mut buffers: Vec<TileBuffer> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let work = &work;
                s.spawn(move || {
                    let mut mine: Vec<TileBuffer> = work
                        .iter()
                        .skip(t)
                        .step_by(threads)
                        .map(|(r, p)| render_tile(*r, *p))
                        .collect();
                    mine.reverse(); // finish order must not matter
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .rev()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    let mut film = Film::new(w, h);
    film.merge_tiles_in_order(&mut buffers);
    film
}

fn bits(film: &Film) -> Vec<u64> {
    film.pixels()
        .iter()
        .flat_map(|p| {
            p.mean
                .iter()
                .chain(&p.m2)
                .map(|v| v.to_bits())
                .chain([p.count as u64])
        })
        .collect()
}

#[test]
fn merge_is_bit_identical_whatever_the_thread_count() {
    let (w, h) = (37, 23);
    let reference = bits(&render(1, w, h));
    for threads in [2, 3, 4, 7] {
        assert!(
            bits(&render(threads, w, h)) == reference,
            "{threads} threads differ"
        );
    }
    // And the merged film holds every sample: 3 passes of 1 + (x + y) % 5 each.
    let film = render(2, w, h);
    for y in 0..h {
        for x in 0..w {
            assert_eq!(film.sample_count(x, y), 3 * (1 + (x + y) % 5));
        }
    }
}

#[test]
#[should_panic(expected = "outside tile")]
fn a_sample_outside_its_tile_is_a_bug() {
    let rect = tiles(16, 16, 8)[0];
    TileBuffer::new(rect).add_sample(8, 0, [1.0; 4]);
}
