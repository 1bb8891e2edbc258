//! Replays what the fuzz targets (fuzz/, `ci/fuzz.sh`) were given and must
//! keep surviving: every input that once crashed one (fuzz/regressions/T/)
//! and every seed (fuzz/corpus/T/), through the same entry the target calls,
//! which panics when what must hold does not.

use std::path::Path;
use tonegate::fuzzing::TARGETS;

/// Runs `f` on every file of `dir/target`; a target with no folder there
/// has nothing to replay, but `dir` itself must exist: a missing folder
/// would otherwise replay nothing and pass.
fn replay(dir: &Path, target: &str, f: fn(&[u8])) -> usize {
    assert!(dir.is_dir(), "{} is missing", dir.display());
    let Ok(entries) = std::fs::read_dir(dir.join(target)) else {
        return 0;
    };
    let mut n = 0;
    for e in entries {
        let path = e.unwrap().path();
        let bytes = std::fs::read(&path).unwrap();
        let outcome = std::panic::catch_unwind(|| f(&bytes));
        assert!(outcome.is_ok(), "{target}: {} fails again", path.display());
        n += 1;
    }
    n
}

#[test]
fn every_regression_input_and_seed_passes_its_target() {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let (mut seeds, mut regressions) = (0, 0);
    for &(target, f) in TARGETS {
        assert!(
            fuzz.join("fuzz_targets")
                .join(format!("{target}.rs"))
                .exists(),
            "no fuzz target file for {target}"
        );
        regressions += replay(&fuzz.join("regressions"), target, f);
        let n = replay(&fuzz.join("corpus"), target, f);
        assert!(n > 0, "{target} has no seeds");
        seeds += n;
    }
    assert!(seeds >= 100, "{seeds} seeds");
    // The committed crash inputs (fuzz/regressions/exr/ has them since the
    // first fuzzing runs); none found would mean the replay lost its way.
    assert!(regressions > 0, "no regression input replayed");
}

/// Hostile inputs found by hand before the fuzzers ran: each passes its
/// target's checks (a named error, a short detail), not only "no panic".
#[test]
fn hand_made_hostile_inputs_pass_their_targets() {
    let mut pfm = b"PF\n1 1\n-1.0\n".to_vec();
    pfm.extend(f32::NAN.to_le_bytes().repeat(3));
    tonegate::fuzzing::hdr(&pfm);
    tonegate::fuzzing::tonemap_params(format!("{}=1", "n".repeat(10_000)).as_bytes());
    tonegate::fuzzing::tonemap_params(format!("operator={}", "x".repeat(10_000)).as_bytes());
    tonegate::fuzzing::runs_json(format!("{{\"{}\": 1}}", "r".repeat(10_000)).as_bytes());
    tonegate::fuzzing::suite(b"scenes = [\"/dev/zero\"]");
    tonegate::fuzzing::scene(b"name = \"x\"\nsize = [4294967295, 4294967295]");
}
