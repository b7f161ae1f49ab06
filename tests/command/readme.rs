//! The README's quick-start commands run as written: every `rayspace …` line of the
//! `## Quick start` block (commands joined by `&&` run in turn), in a scratch folder,
//! with `$RAYSPACE_SCENES` expanded. Lines that read the shared scenes need them (a
//! `SKIPPED:` line without, a failure where they are required).

use std::process::Command;

#[test]
fn quick_start_commands_run_as_written() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let section = &readme[readme
        .find("## Quick start")
        .expect("a quick-start section")..];
    let start = section.find("```sh\n").expect("a sh block") + 6;
    let block = &section[start..start + section[start..].find("```").expect("closed")];
    let scenes = testkit::scenes();
    let dir = testkit::temp_dir("readme");
    let mut ran = 0;
    for line in block.lines() {
        let code = line.split(" #").next().unwrap_or("").trim();
        if code.is_empty() {
            continue;
        }
        let needs_scenes = ["$RAYSPACE_SCENES", "sponza", "kitchen"]
            .iter()
            .any(|w| code.contains(w));
        let scenes_dir = match (&scenes, needs_scenes) {
            (Some(d), _) => d.display().to_string(),
            (None, true) => {
                testkit::skip(
                    "scenes",
                    format!("README line needs the shared scenes: {code}"),
                );
                continue;
            }
            (None, false) => String::new(),
        };
        for cmd in code.split("&&") {
            let words: Vec<String> = cmd
                .split_whitespace()
                .map(|w| w.replace("$RAYSPACE_SCENES", &scenes_dir))
                .collect();
            assert_eq!(words[0], "rayspace", "README quick start: {cmd}");
            let out = Command::new(env!("CARGO_BIN_EXE_rayspace"))
                .args(&words[1..])
                .current_dir(&dir)
                .env("RAYSPACE_SCENES", &scenes_dir)
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "README quick start: {cmd}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 3, "{ran} commands ran");
    for f in ["spheres.png", "office.png"] {
        assert!(dir.join(f).exists(), "{f}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
