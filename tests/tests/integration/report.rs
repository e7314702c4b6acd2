//! The report (issue 8): from a simulated calibration and two streams, `trainer report` writes
//! one self-contained page that shows every figure it promises, and each figure as a file.

use trainer::report::FIGURES;

use crate::{at, sim, trainer as run_trainer};

#[test]
fn the_report_holds_every_promised_figure_inline_and_as_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name| at(dir.path(), name);
    let effect = ["--effect", "thermal-rate"];
    sim(&[
        &["generate", "paper", "--seed", "4", "--out", &p("p.csv")][..],
        &effect,
    ]
    .concat())
    .unwrap();
    sim(&[
        &["generate", "stream", "--seed", "5", "--out", &p("a.csv")][..],
        &effect,
    ]
    .concat())
    .unwrap();
    sim(&[
        &["generate", "stream", "--seed", "6", "--out", &p("b.csv")][..],
        &effect,
    ]
    .concat())
    .unwrap();
    let out = dir.path().join("report");
    let report = |points: &str| {
        run_trainer(&[
            "report",
            "--points",
            points,
            "--train-stream",
            &p("a.csv"),
            "--valid-stream",
            &p("b.csv"),
            "--out",
            &out.display().to_string(),
            "--quiet",
        ])
    };
    report(&p("p.csv")).unwrap();

    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(FIGURES.len() >= 6);
    for (name, caption) in FIGURES {
        let svg = std::fs::read_to_string(out.join(name)).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("<text"), "{name}");
        assert!(
            page.contains(&format!("href=\"{name}\"")),
            "{name} not linked"
        );
        assert!(page.contains(caption), "{name}: caption missing");
        // The page carries the figure itself, not only a link to it.
        assert!(page.contains(&svg), "{name} not inline");
    }
    // Axis labels with units, and the tables beside the figures.
    for text in [
        "reference rate (°/s)",
        "T (°C)",
        "LOO residual (°/s)",
        "error (°/h)",
        "filtered dT/dt (°C/min)",
        "Named causes: <b>thermal-rate</b>",
        "GPR paper",
    ] {
        assert!(page.contains(text), "missing {text}");
    }
    // Self-contained: nothing fetched from elsewhere.
    for external in ["<script", "<link", "src=", "url("] {
        assert!(!page.contains(external), "{external}");
    }
    // An output never replaces an input: a rate table that happens to sit where a figure goes.
    let table = out.join("qq.svg");
    std::fs::copy(dir.path().join("p.csv"), &table).unwrap();
    let clash = report(&table.display().to_string());
    assert!(clash.is_err());
    assert_eq!(
        std::fs::read(&table).unwrap(),
        std::fs::read(dir.path().join("p.csv")).unwrap()
    );
}
