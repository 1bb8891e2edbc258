//! The lists of operators written for people are the registry's: every
//! operator `GET /api/v1/operators` answers with (and each other name) is in
//! the `operator` parameter of `POST /api/v1/tonemap`, so the text cannot
//! drift from the code as a hand-written list did (it left out aces2); and
//! docs/operators.md's table has a row for each built-in operator and no
//! other.

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

/// docs/operators.md's table of operators (rows opening with a backquoted
/// name) names exactly the built-in operators, each once.
#[test]
fn the_operator_table_in_the_docs_is_the_registry() {
    let text = std::fs::read_to_string(common::repo().join("docs/operators.md")).unwrap();
    let start = text
        .find("| Name | Kind |")
        .expect("docs/operators.md has the operator table");
    let rows: Vec<&str> = text[start..]
        .lines()
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .collect();
    let mut documented: Vec<String> = rows
        .iter()
        .map(|r| {
            let cell = r.trim_start_matches('|').trim_start();
            let name = cell.strip_prefix('`').and_then(|c| c.split('`').next());
            name.unwrap_or_else(|| panic!("a row without a name: {r}"))
                .to_owned()
        })
        .collect();
    documented.sort();
    // The built-in ones: other tests of this binary register their own.
    let mut registry: Vec<String> = tonegate::operators::builtin()
        .iter()
        .map(|op| op.name().to_owned())
        .collect();
    registry.sort();
    assert_eq!(documented, registry);
}

/// docs/commands.md's synopsis of `tonemap --operator` lists the built-in
/// operators, each once, in the registry's order.
#[test]
fn the_operator_choices_in_the_commands_synopsis_are_the_registry() {
    let text = std::fs::read_to_string(common::repo().join("docs/commands.md")).unwrap();
    let start = text
        .find("[--operator ")
        .expect("docs/commands.md has tonemap's --operator")
        + "[--operator ".len();
    let end = start + text[start..].find(']').unwrap();
    // The list wraps onto the next line of the synopsis.
    let listed: Vec<String> = text[start..end]
        .split('|')
        .map(|n| n.trim().to_owned())
        .collect();
    let registry: Vec<String> = tonegate::operators::builtin()
        .iter()
        .map(|op| op.name().to_owned())
        .collect();
    assert_eq!(listed, registry);
}

/// The dashboard's list of stage series (`STAGES` in its app.js) is the
/// plan's stages, in plan order, so a new stage's trend is drawn.
#[test]
fn the_dashboards_stage_list_is_the_plans() {
    let js = std::fs::read_to_string(common::repo().join("src/server/dashboard/app.js")).unwrap();
    let line = js
        .lines()
        .find(|l| l.starts_with("const STAGES = ["))
        .expect("app.js declares STAGES");
    let listed: Vec<&str> = line["const STAGES = [".len()..]
        .trim_end_matches("];")
        .split(',')
        .map(|s| s.trim().trim_matches('"'))
        .collect();
    assert_eq!(listed, tonegate::plan::Stage::NAMES);
}

/// Every endpoint the OpenAPI document has (each method of each path) has
/// its row in docs/api.md's table, by method and path up to its first
/// parameter: an endpoint added without its documentation fails here.
#[test]
fn every_endpoint_has_its_row_in_the_api_docs() {
    use utoipa::OpenApi;
    let doc = serde_json::to_value(tonegate::server::ApiDoc::openapi()).unwrap();
    let text = std::fs::read_to_string(crate::common::repo().join("docs/api.md")).unwrap();
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| `")).collect();
    let mut missing = Vec::new();
    let mut seen = 0;
    for (path, methods) in doc["paths"].as_object().unwrap() {
        let prefix = path.split('{').next().unwrap();
        for method in methods.as_object().unwrap().keys() {
            seen += 1;
            let wanted = format!("`{} {prefix}", method.to_uppercase());
            if !rows.iter().any(|r| r.contains(&wanted)) {
                missing.push(format!("{} {path}", method.to_uppercase()));
            }
        }
    }
    assert!(seen >= 25, "only {seen} endpoints in the document");
    assert!(missing.is_empty(), "docs/api.md has no row for {missing:?}");
}
