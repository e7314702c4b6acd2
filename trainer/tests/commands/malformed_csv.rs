//! Malformed CSV never panics the loaders: every damaged file is read or refused with an error that
//! names the file, and, for a bad cell, its line and column (docs/reliability.md).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use fog_data::stream::Stream;
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trainer::data::points::Points;

/// Damaged files per loader.
const CASES: usize = 3000;

/// A clean rate table (5 temperatures × 6 rates) and a clean 1 Hz stream.
fn clean() -> [String; 2] {
    let mut points = String::from("temp_c,voltage_v,rate_dps,setpoint_c\n");
    for t in [-20.0, 0.0, 20.0, 40.0, 60.0] {
        for w in [-40.0, -10.0, -1.0, 1.0, 10.0, 40.0] {
            points.push_str(&format!("{t},{},{w},{t}\n", 0.038 * w + 1e-3 * t));
        }
    }
    let mut stream = String::from("time_s,temp_c,voltage_v,rate_dps,air_c\n");
    for k in 0..200 {
        let t = 20.0 + 0.01 * f64::from(k);
        stream.push_str(&format!("{k},{t},{},10,{t}\n", 0.38 + 1e-3 * t));
    }
    [points, stream]
}

/// Cell contents a logger or a hand edit can leave.
const GARBAGE: [&str; 14] = [
    "abc", "", "1.2.3", "--1", "0x10", "NaN", "inf", "-inf", "1e999", "-1e400", "٣", " 5 ",
    "\"7\"", "1,5",
];

/// One damaged copy of `text`, and the (line, column) of a bad cell when the damage is one.
fn damage(text: &str, rng: &mut impl Rng) -> (Vec<u8>, Option<(usize, String)>) {
    let lines: Vec<&str> = text.lines().collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    match rng.random_range(0..8) {
        0 => {
            let line = rng.random_range(1..lines.len());
            let col = rng.random_range(0..header.len());
            let token = GARBAGE[rng.random_range(0..GARBAGE.len())];
            let mut cells: Vec<&str> = lines[line].split(',').collect();
            cells[col] = token;
            let mut out = lines.clone();
            let edited = cells.join(",");
            out[line] = &edited;
            (
                (out.join("\n") + "\n").into_bytes(),
                Some((line + 1, header[col].to_owned())),
            )
        }
        1 => {
            let col = rng.random_range(0..header.len());
            let out: Vec<String> = lines
                .iter()
                .map(|l| {
                    let mut c: Vec<&str> = l.split(',').collect();
                    c.remove(col);
                    c.join(",")
                })
                .collect();
            ((out.join("\n") + "\n").into_bytes(), None)
        }
        2 => {
            let cut = rng.random_range(0..text.len());
            (text.as_bytes()[..cut].to_vec(), None)
        }
        3 => {
            let at = rng.random_range(1..lines.len());
            let junk: Vec<u8> = (0..rng.random_range(1..40)).map(|_| rng.random()).collect();
            let mut out = lines[..at].join("\n").into_bytes();
            out.push(b'\n');
            out.extend(junk);
            out.push(b'\n');
            out.extend(lines[at..].join("\n").into_bytes());
            (out, None)
        }
        4 => {
            let mut out = vec![0xEF, 0xBB, 0xBF];
            out.extend(text.replace('\n', "\r\n").into_bytes());
            (out, None)
        }
        5 => {
            let keep = rng.random_range(0..2);
            (lines[..keep].join("\n").into_bytes(), None)
        }
        6 => {
            let line = rng.random_range(1..lines.len());
            let mut out = lines.clone();
            let short = lines[line]
                .rsplit_once(',')
                .map_or("", |(a, _)| a)
                .to_owned();
            out[line] = &short;
            ((out.join("\n") + "\n").into_bytes(), None)
        }
        _ => {
            let tab = if rng.random() {
                text.replace(',', "\t")
            } else {
                text.to_owned()
            };
            let huge = tab.replacen("0.038", "1e300*", 1);
            (huge.into_bytes(), None)
        }
    }
}

/// Loads every damaged file with `load`; panics are failures, errors must name the file (and the
/// damaged cell's line and column). Returns (read, refused).
fn check(text: &str, seed: u64, load: &dyn Fn(&Path) -> Result<usize, String>) -> (usize, usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("damaged.csv");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut read, mut refused) = (0, 0);
    for case in 0..CASES {
        let (bytes, cell) = damage(text, &mut rng);
        std::fs::write(&path, &bytes).unwrap();
        let outcome = catch_unwind(AssertUnwindSafe(|| load(&path))).unwrap_or_else(|_| {
            panic!(
                "case {case} panicked: {:?}",
                String::from_utf8_lossy(&bytes)
            )
        });
        match outcome {
            Ok(_) => read += 1,
            Err(e) => {
                refused += 1;
                assert!(e.contains("damaged.csv"), "case {case}: {e}");
                if let Some((line, column)) = cell
                    && (e.contains("not a number") || e.contains("not a finite number"))
                {
                    assert!(
                        e.contains(&format!("line {line}, column {column}")),
                        "case {case}: {e}"
                    );
                }
            }
        }
    }
    (read, refused)
}

#[test]
fn damaged_points_and_streams_are_read_or_refused_with_their_place_never_a_panic() {
    let [points, stream] = clean();
    let (read, refused) = check(&points, 1, &|p| {
        Points::load(p, &[], None, None)
            .map(|p| p.len())
            .map_err(|e| format!("{:#}", anyhow::Error::from(e)))
    });
    eprintln!("points: {CASES} damaged files, {read} read, {refused} refused");
    assert!(read > CASES / 10 && refused > CASES / 2);
    let (read, refused) = check(&stream, 2, &|p| {
        Stream::load(p, &[])
            .map(|s| s.len())
            .map_err(|e| format!("{:#}", anyhow::Error::from(e)))
    });
    eprintln!("streams: {CASES} damaged files, {read} read, {refused} refused");
    assert!(read > CASES / 10 && refused > CASES / 2);
}
