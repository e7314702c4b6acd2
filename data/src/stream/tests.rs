use super::*;

#[test]
fn a_minute_of_handling_in_a_static_log_is_screened_and_nothing_else() {
    // 20 minutes at 1 Hz of noise (a deterministic ripple), handled from 600 to 660 s.
    let n = 1200;
    let time_s: Vec<f64> = (0..n).map(f64::from).collect();
    let ripple = |i: u32| 0.01 * (f64::from(i) * 1.7).sin();
    let mut output: Vec<f64> = (0..n).map(ripple).collect();
    for (i, v) in output.iter_mut().enumerate().skip(600).take(60) {
        *v += 20.0 * (i as f64 * 0.3).sin();
    }
    let lines: Vec<u64> = (2..2 + u64::from(n)).collect();
    let mut rate = vec![0.0; n as usize];
    let handled = screen_handling(&time_s, &output, &mut rate, &lines);
    assert_eq!(handled.len(), 1);
    assert_eq!(
        (handled[0].line, handled[0].n, handled[0].span_s),
        (602, 60, [600.0, 659.0])
    );
    assert!(handled[0].scatter_ratio > HANDLED_SCATTER);
    assert_eq!(rate.iter().filter(|r| r.is_nan()).count(), 60);
    assert!(rate[599] == 0.0 && rate[660] == 0.0);
    // A window that starts inside the handled minute keeps the part of it that it holds.
    let log = Stream {
        time_s: time_s.clone(),
        temp_c: vec![20.0; n as usize],
        voltage_v: output.clone(),
        rate_dps: rate.clone(),
        lines: lines.clone(),
        step_s: 1.0,
        time_issues: Vec::new(),
        handled: handled.clone(),
        history: 0,
        after_s: None,
    };
    let part = log.window(Window {
        start_s: Some(630.0),
        end_s: None,
    });
    assert_eq!(part.handled.len(), 1);
    assert_eq!((part.handled[0].line, part.handled[0].n), (632, 30));
    assert_eq!(part.handled[0].span_s, [630.0, 659.0]);
    assert!(
        log.window(Window {
            start_s: Some(700.0),
            end_s: None
        })
        .handled
        .is_empty()
    );
    // A stream on a rate table is not a static log: never screened.
    let mut moving: Vec<f64> = (0..n).map(|i| f64::from(i / 90 % 3)).collect();
    assert!(screen_handling(&time_s, &output, &mut moving, &lines).is_empty());
}

fn load(text: &str) -> Result<Stream, DataError> {
    let mut f = tempfile::NamedTempFile::new().unwrap();
    std::io::Write::write_all(&mut f, text.as_bytes()).unwrap();
    Stream::load(f.path(), &[])
}

#[test]
fn empty_reference_is_unknown_and_time_problems_are_collected() {
    let s = load(
        "time_s,temp_c,voltage_v,rate_dps\n0,20,0.1,1\n1,20,0.1,\n2,20,0.1,1\n2,20,0.1,1\n\
         1.5,20,0.1,1\n10,20,0.1,1\n11,20,0.1,1\n",
    )
    .unwrap();
    assert_eq!(s.len(), 7);
    assert!(s.rate_dps[1].is_nan());
    assert_eq!(s.step_s, 1.0);
    assert_eq!(
        s.time_issues,
        vec![
            TimeIssue::Duplicate { line: 5 },
            TimeIssue::Backwards {
                line: 6,
                step_s: -0.5
            },
            TimeIssue::Gap {
                line: 7,
                step_s: 8.5
            },
        ]
    );
    let said: Vec<String> = s.time_issues.iter().map(ToString::to_string).collect();
    assert_eq!(
        said,
        [
            "line 5: the timestamp repeats",
            "line 6: time goes back 0.5 s",
            "line 7: time jumps 8.5 s (a power cycle or a logger pause)"
        ]
    );
}

#[test]
fn an_empty_temperature_is_still_an_error() {
    let e = load("time_s,temp_c,voltage_v,rate_dps\n0,,0.1,1\n").unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
}

#[test]
fn a_window_keeps_its_span_its_time_problems_and_its_history() {
    let s = load(
        "time_s,temp_c,voltage_v,rate_dps\n100,20,0.1,1\n101,20,0.1,1\n102,20,0.1,1\n\
         110,20,0.1,1\n111,20,0.1,1\n",
    )
    .unwrap();
    let w: Window = "1:".parse().unwrap();
    let part = s.window(w);
    // The sample before the window is its history: kept for the feature state, its
    // reference removed, not written.
    assert_eq!(part.time_s, s.time_s);
    assert_eq!(part.history, 1);
    assert_eq!(part.inside(), 1..5);
    assert!(part.rate_dps[0].is_nan() && part.rate_dps[1..].iter().all(|r| *r == 1.0));
    assert_eq!(part.referenced(), vec![1, 2, 3, 4]);
    assert_eq!(part.time_issues, s.time_issues);
    let head = s.window(":2".parse().unwrap());
    assert_eq!(head.time_s, vec![100.0, 101.0]);
    assert_eq!(head.history, 0);
    assert!(head.time_issues.is_empty());
    // The log goes on after it, in the same power-on; a window that a gap ends, or that
    // reaches the log's end, has nothing after it.
    assert_eq!((head.after_s, part.after_s), (Some(102.0), None));
    assert!(
        s.time_issues
            .iter()
            .any(|i| i.is_restart() && i.line() == 5)
    );
    assert_eq!(s.window(":5".parse().unwrap()).after_s, None);
    // A window of a window keeps the first one's history, and adds to it.
    let inner = part.window("2:11".parse().unwrap());
    assert_eq!(inner.time_s, vec![100.0, 101.0, 102.0, 110.0]);
    assert_eq!((inner.history, inner.referenced()), (2, vec![2, 3]));
    assert_eq!(inner.after_s, Some(111.0));
    // A minute left out right after the window held nothing to fit: the data resume later,
    // unless a power cycle comes first.
    let mut gap = load(
        "time_s,temp_c,voltage_v,rate_dps\n100,20,0.1,1\n101,20,0.1,1\n102,20,0.1,1\n\
         103,20,0.1,1\n",
    )
    .unwrap();
    gap.rate_dps[2] = f64::NAN;
    assert_eq!(gap.window(":2".parse().unwrap()).after_s, Some(103.0));
    let mut cycled = s.clone();
    cycled.rate_dps[2] = f64::NAN;
    assert_eq!(cycled.window(":2".parse().unwrap()).after_s, None);
    // No reference follows: nothing after it was fitted, unless the log it is a window of
    // goes on.
    let mut tail = gap.clone();
    tail.rate_dps[3] = f64::NAN;
    assert_eq!(tail.window(":2".parse().unwrap()).after_s, None);
    gap.rate_dps[1] = f64::NAN;
    let outer = gap.window(":3".parse().unwrap());
    assert_eq!(outer.after_s, Some(103.0));
    assert_eq!(outer.window(":1".parse().unwrap()).after_s, Some(103.0));
    assert_eq!(part.window(":11".parse().unwrap()).history, 1);
    // A clock that jumps back (a power cycle whose counter restarted): the window runs from
    // its first sample inside to its last, and a sample outside between them is not scored.
    let mut back = s.clone();
    back.time_s = vec![100.0, 101.0, 102.0, 100.5, 101.5];
    let part = back.window("1:2".parse().unwrap());
    assert_eq!((part.history, part.len()), (1, 5));
    assert_eq!(part.referenced(), vec![1, 4]);
    for bad in ["", "5", "a:b", "3:1", "inf:"] {
        assert!(bad.parse::<Window>().is_err(), "{bad}");
    }
}
