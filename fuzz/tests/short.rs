//! The bounded fuzzing run of CI: a fixed, seeded number of mutated inputs per loader must
//! find no panic, no hang, no allocation over the cap and no wrong result. Long runs:
//! `cargo run --release -p fuzz -- --minutes N`.

#[test]
fn every_loader_survives_a_seeded_run() {
    let out = std::env::temp_dir().join(format!("rayspace-fuzz-{}", std::process::id()));
    let cfg = fuzz::Config {
        targets: fuzz::targets::NAMES.iter().map(|s| s.to_string()).collect(),
        execs: Some(4000),
        seconds: None,
        threads: 2,
        seed: 20261127,
        out: out.clone(),
        scenes: scene::scenes_dir(),
    };
    let reports = fuzz::run(&cfg).unwrap();
    eprintln!("{}", fuzz::table(&reports));
    assert_eq!(reports.len(), fuzz::targets::NAMES.len());
    for r in &reports {
        assert_eq!(r.execs, 4000, "{}", r.target);
        // The mutations reach both sides of every loader.
        assert!(r.accepted > 0 && r.rejected > 0, "{}: {r:?}", r.target);
        assert!(r.clean(), "{}: {:#?}", r.target, r.findings);
    }
    let _ = std::fs::remove_dir_all(&out);
}
