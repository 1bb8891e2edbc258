//! `tonegate history pending`: the images an object store did not take
//! (down past the retry budget, or refusing), kept in the history and served
//! from there until they are sent on or dropped.

use super::DbArgs;
use super::{invalid, json_text};
use clap::Args;
use std::process::ExitCode;
use tonegate::error::Result;
use tonegate::history::History;

#[derive(Args)]
pub struct PendingArgs {
    #[command(flatten)]
    pub db: DbArgs,
    /// Send each pending image to the store it belongs in; what the store
    /// takes leaves the history's table, the rest stays pending.
    #[arg(long, conflicts_with = "drop")]
    pub upload: bool,
    /// Drop the pending images and the artifact names that use them (the
    /// runs' metrics, checks and reports stay).
    #[arg(long)]
    pub drop: bool,
    /// Print the list as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn pending(a: PendingArgs) -> Result<ExitCode> {
    // The runner's budget: an upload waits for a store coming back.
    a.db.set_retry(60);
    if !a.db.is_url() && !a.db.db.exists() {
        return Err(invalid(format!("no history at {}", a.db.shown())));
    }
    let h = History::open(&a.db.db)?;
    if a.upload || a.drop {
        let done = if a.upload {
            h.upload_pending()?
        } else {
            h.drop_pending()?
        };
        if a.json {
            println!("{}", json_text("the pending images", &done)?);
        } else if a.upload {
            println!(
                "{} pending image(s) sent to their store ({:.1} MiB); {} still pending",
                done.images,
                done.bytes as f64 / 1048576.0,
                done.still_pending
            );
        } else {
            println!(
                "{} pending image(s) dropped ({:.1} MiB) with {} artifact name(s)",
                done.images,
                done.bytes as f64 / 1048576.0,
                done.names
            );
        }
        // Exit 1 while some image is still waiting for its store.
        return Ok(ExitCode::from(u8::from(done.still_pending > 0)));
    }
    let list = h.pending_artifacts()?;
    if a.json {
        println!("{}", json_text("the pending images", &list)?);
        return Ok(ExitCode::SUCCESS);
    }
    if list.is_empty() {
        println!("no pending images: every stored image is where it belongs");
    }
    for p in &list {
        let mut of = Vec::new();
        if !p.runs.is_empty() {
            of.push(format!("runs {:?}", p.runs));
        }
        if !p.submissions.is_empty() {
            of.push(format!("frames submissions {:?}", p.submissions));
        }
        println!(
            "{}  {} bytes  for {}  {}: {}",
            p.sha256,
            p.size,
            p.store,
            of.join(", "),
            p.reason
        );
    }
    Ok(ExitCode::SUCCESS)
}
