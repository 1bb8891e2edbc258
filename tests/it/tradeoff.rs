//! `tonegate tradeoff`: every knob swept, time and error measured against a
//! supersampled f64 reference, the Pareto front marked, plots written.

use std::path::PathBuf;
use std::process::Command;

#[test]
fn the_sweep_measures_every_configuration_and_marks_a_consistent_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let db = dir.path().join("h.sqlite");
    let o = Command::new(env!("CARGO_BIN_EXE_tonegate"))
        .args([
            "tradeoff",
            "grid-static",
            "--frames",
            "0",
            "--reference-spp",
            "4",
            "--repeats",
            "2",
        ])
        .arg("--out")
        .arg(&out)
        .arg("--db")
        .arg(&db)
        .arg("--json")
        .current_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")))
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = String::from_utf8_lossy(&o.stdout).replace("1e999", "1e308");
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    let points = report["points"].as_array().unwrap();
    // f32/f16 x block/pingpong/tree/subgroup tree x manual/hardware x
    // 1/4/16 spp; no bloom here; then at 1 spp no AA and the TAA
    // configurations (docs/taa.md): every history filter x feedback rule x
    // clipping box, and the defaults with a linear blend and with the
    // sharpen.
    assert_eq!(points.len(), 48 + 15);
    let taa: Vec<&serde_json::Value> = points
        .iter()
        .filter(|p| !p["knobs"]["taa"].is_null())
        .collect();
    assert_eq!(taa.len(), 15);
    let taa_psnr = |variant: &str, filter: &str, feedback: &str, blend: &str| {
        taa.iter()
            .find(|p| {
                let t = &p["knobs"]["taa"];
                t["variant"] == variant
                    && t["history_filter"] == filter
                    && t["feedback"] == feedback
                    && t["blend"] == blend
                    && t["sharpen"].as_f64() == Some(0.0)
            })
            .unwrap_or_else(|| panic!("no {variant} {filter} {feedback} {blend} point"))["psnr"]
            .as_f64()
            .unwrap()
    };
    // The static grid: the history of the 6 frames averages 6 jitter
    // offsets, which beats one unjittered sample against the supersampled
    // reference, with the defaults and with the thesis's luminance rule.
    let off = taa_psnr("off", "catmull_rom", "motion", "tonemapped");
    let clip = taa_psnr("clip", "catmull_rom", "motion", "tonemapped");
    assert!(clip > off + 3.0, "no AA {off} dB, clip {clip} dB");
    let thesis_rule = taa_psnr("clip", "bilinear", "luminance", "tonemapped");
    assert!(
        thesis_rule > off + 3.0,
        "no AA {off} dB, clip {thesis_rule} dB"
    );
    for p in points {
        assert!(p["ms"].as_f64().unwrap() > 0.0, "{p}");
        // At the reference's own spp in f32, the adaptation luminance is the
        // reference's to the statistics bound (1e-5 relative, docs/tolerances.md); at other
        // spp it is the log-average of other samples and really differs.
        if p["knobs"]["spp"] == 4 && p["knobs"]["hdr_format"] == "rgba32_float" {
            assert!(p["log_average_rel_error"].as_f64().unwrap() < 1e-5, "{p}");
        }
    }
    let psnr = |spp: u64, f: &str, r: &str, e: &str| {
        points
            .iter()
            .find(|p| {
                p["knobs"]["spp"] == spp
                    && p["knobs"]["hdr_format"] == f
                    && p["knobs"]["reduction"] == r
                    && p["knobs"]["env_filter"] == e
            })
            .unwrap()["psnr"]
            .as_f64()
            .unwrap()
    };
    // Against a 4-spp reference the 4-spp render is the closest (same
    // samples, f32 vs f64 rounding only); 1 spp aliases.
    let (one, four) = (
        psnr(1, "rgba32_float", "block_partials", "manual"),
        psnr(4, "rgba32_float", "block_partials", "manual"),
    );
    assert!(four > 60.0 && one < 30.0, "1 spp {one} dB, 4 spp {four} dB");
    // The front: no marked point is dominated by another point.
    let front: Vec<&serde_json::Value> = points.iter().filter(|p| p["pareto"] == true).collect();
    assert!(!front.is_empty());
    for f in &front {
        let (fm, fq) = (f["ms"].as_f64().unwrap(), f["psnr"].as_f64().unwrap());
        for p in points {
            let (m, q) = (p["ms"].as_f64().unwrap(), p["psnr"].as_f64().unwrap());
            assert!(
                !(m <= fm && q >= fq && (m < fm || q > fq)),
                "{f} is dominated by {p}"
            );
        }
    }
    let svg = std::fs::read_to_string(out.join("tradeoff-grid-static.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("class=\"pareto\""));
    assert_eq!(svg.matches("class=\"pareto\"").count(), front.len());
    assert!(out.join("tradeoff.svg").exists() && out.join("tradeoff.json").exists());
    // Stored in the history with its points.
    let h = tonegate::history::History::open_read_only(&db).unwrap();
    let runs = h.runs(5).unwrap();
    assert_eq!(runs[0].kind.as_str(), "tradeoff");
    assert_eq!(runs[0].status.as_str(), "passed");
}
