//! Seeded, time-bounded campaign (issue 14, item 6): the default scenario
//! (`sweep.toml`) with one numeric value replaced by a value from the classes
//! that found bugs (zero, signs, huge, tiny, 2^53 + 1, i64::MAX, non-finite)
//! into the public parser `host::scenario::Scenario::parse`. Counts tried /
//! crashed (panic) / hung (over 2 s) and requires the last two to be zero.
//! The shared SplitMix64 (`fmi2_export::testing`) gives a fixed sequence.
use std::time::{Duration, Instant};

const BASE: &str = include_str!("../../../sweep.toml");

fn next(s: &mut u64) -> u64 {
    let mut g = fmi2_export::testing::SplitMix64(*s);
    let r = g.next_u64();
    *s = g.0;
    r
}

#[test]
fn mutated_scenarios_never_panic_or_hang() {
    const VALUES: [&str; 16] = [
        "0",
        "-0.0",
        "-1",
        "1e-30",
        "1e-300",
        "1e300",
        "-1e300",
        "1.7976931348623157e308",
        "9007199254740993",
        "9223372036854775807",
        "-9223372036854775808",
        "nan",
        "inf",
        "-inf",
        "0.5",
        "\"x\"",
    ];
    // lines of the form `key = <number>`
    let lines: Vec<&str> = BASE.lines().collect();
    let numeric: Vec<usize> = lines
        .iter()
        .enumerate()
        .filter(|(_, l)| {
            let Some((_, v)) = l.split_once('=') else {
                return false;
            };
            let v = v.split('#').next().unwrap().trim();
            !l.trim_start().starts_with('#') && v.parse::<f64>().is_ok()
        })
        .map(|(i, _)| i)
        .collect();
    assert!(numeric.len() > 10);
    let (mut tried, mut crashed, mut hung, mut refused) = (0, 0, 0, 0);
    let mut seed = 5u64;
    let budget = Instant::now();
    for _ in 0..3000 {
        let i = numeric[(next(&mut seed) % numeric.len() as u64) as usize];
        let v = VALUES[(next(&mut seed) % VALUES.len() as u64) as usize];
        let key = lines[i].split_once('=').unwrap().0.trim();
        let text: String = lines
            .iter()
            .enumerate()
            .map(|(j, l)| {
                if j == i {
                    format!("{key} = {v}\n")
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| host::scenario::Scenario::parse(&text).map(|_| ()));
        tried += 1;
        match r {
            Err(_) => {
                crashed += 1;
                eprintln!("panic: {key} = {v}");
            }
            Ok(Err(_)) => refused += 1,
            Ok(Ok(())) => {}
        }
        if t0.elapsed() > Duration::from_secs(2) {
            hung += 1;
        }
        if budget.elapsed() > Duration::from_secs(25) {
            break;
        }
    }
    eprintln!(
        "fuzz scenarios: tried {tried} / crashed {crashed} / hung {hung} / refused {refused}"
    );
    assert_eq!((crashed, hung), (0, 0));
}
