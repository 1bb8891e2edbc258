//! The OpenAPI document's list of operators is the registry's: every
//! operator `GET /api/v1/operators` answers with (and each other name) is in
//! the `operator` parameter of `POST /api/v1/tonemap`, so the text cannot
//! drift from the code as a hand-written list did (it left out aces2).

use crate::common;
use crate::common::server::start;

#[tokio::test]
async fn the_tonemap_operator_parameter_lists_every_registered_operator() {
    let dir = tempfile::tempdir().unwrap();
    let seeded = common::seed_empty(dir.path());
    let s = start(&seeded, |_| {}).await;
    let (_, doc) = s.json("/api/v1/openapi.json").await;
    let params = doc["paths"]["/api/v1/tonemap"]["post"]["parameters"]
        .as_array()
        .unwrap_or_else(|| panic!("no parameters: {doc}"));
    let text = params
        .iter()
        .find(|p| p["name"] == "operator")
        .and_then(|p| p["description"].as_str())
        .unwrap_or_else(|| panic!("no operator parameter: {params:?}"))
        .to_owned();
    let (_, listed) = s.json("/api/v1/operators").await;
    let listed = listed.as_array().unwrap().clone();
    assert!(listed.len() >= 10, "{listed:?}");
    for op in &listed {
        let name = op["name"].as_str().unwrap();
        assert!(text.contains(name), "{name} missing from: {text}");
    }
    for name in tonegate::operators::names() {
        assert!(text.contains(name), "{name} missing from: {text}");
    }
    assert!(text.contains("aces2") && text.contains("seed000"), "{text}");
}
