//! The graphics API's own validation: the Khronos validation layer on Vulkan
//! (synchronization validation included when `VK_LAYER_ENABLES` asks for
//! it), `KHR_debug` on GL. Asked for with wgpu's `WGPU_VALIDATION=1`; then
//! every message of error severity the driver layer reports becomes a
//! [`GpuError::LayerError`](crate::gpu::GpuError) of the frame that raised it, as
//! wgpu's own test harness fails a test on one. docs/adapters.md says how CI
//! runs it.
//!
//! wgpu hands those messages to the `log` crate; this module is the logger
//! (installed only when validation is asked for, and only if the program has
//! no other). Its messages are process-wide: with validation on, open one
//! device at a time.

use std::sync::Mutex;

/// One message of the validation layer (or GL's debug output), with the
/// queues, command buffers and objects (their `tonegate.<stage>` labels)
/// that wgpu logs after it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LayerMessage {
    pub error: bool,
    /// Known to be false (`is_known_false`): not reported.
    pub dropped: bool,
    pub text: String,
}

struct Sink {
    messages: Mutex<Vec<LayerMessage>>,
    layer_missing: Mutex<bool>,
    /// Every message reported since the process started: (errors, warnings).
    seen: Mutex<(u64, u64)>,
}

static SINK: Sink = Sink {
    messages: Mutex::new(Vec::new()),
    layer_missing: Mutex::new(false),
    seen: Mutex::new((0, 0)),
};

impl log::Log for Sink {
    fn enabled(&self, m: &log::Metadata) -> bool {
        m.target().starts_with("wgpu_hal")
    }

    fn log(&self, r: &log::Record) {
        if !self.enabled(r.metadata()) {
            return;
        }
        match r.level() {
            log::Level::Error | log::Level::Warn => {
                let text = r.args().to_string();
                let mut v = self.messages.lock().unwrap_or_else(|p| p.into_inner());
                // wgpu logs a message's objects and labels as records of
                // their own, each starting with a tab; a dropped message
                // stays in the list, marked, until the next one.
                let continues = text.starts_with('\t');
                match v.last_mut() {
                    Some(last) if continues => {
                        last.text.push('\n');
                        last.text.push_str(&text);
                    }
                    _ if continues => {}
                    _ => {
                        if v.last().is_some_and(|m| m.dropped) {
                            v.pop();
                        }
                        if !is_known_false(&text) {
                            let mut seen = self.seen.lock().unwrap_or_else(|p| p.into_inner());
                            if r.level() == log::Level::Error {
                                seen.0 += 1;
                            } else {
                                seen.1 += 1;
                            }
                        }
                        v.push(LayerMessage {
                            error: r.level() == log::Level::Error,
                            dropped: is_known_false(&text),
                            text,
                        })
                    }
                }
            }
            _ => {
                let text = r.args().to_string();
                if text.contains("VALIDATION requested, but unable to find layer") {
                    *self.layer_missing.lock().unwrap_or_else(|p| p.into_inner()) = true;
                }
            }
        }
    }

    fn flush(&self) {}
}

/// Messages dropped as known to be false, each with why.
///
/// - The Khronos layer of Debian 12 (1.3.239) checks SPIR-V with a
///   SPIRV-Tools older than the `SourceLanguage` value 10 (WGSL), which wgpu
///   writes into `OpSource` whenever debug names are on (and they must be,
///   for the layer's messages to reach the gate): every shader module is
///   then refused as "Invalid source language operand: 10". The cost:
///   the layer's own SPIR-V check stops there, so on that version the
///   modules are validated by naga (in wgpu, and `cargo test`) and not again
///   by SPIRV-Tools; the pipelines, barriers and resources still are.
/// - Mesa's EGL, on a machine without a GPU, first tries a hardware (DRI)
///   driver when wgpu initialises a display, fails, and goes on with
///   llvmpipe; EGL's debug callback reports the attempt as an error
///   ("eglInitialize … DRI2: failed to load driver"), though nothing failed.
fn is_known_false(text: &str) -> bool {
    (text.contains("UNASSIGNED-CoreValidation-Shader-InconsistentSpirv")
        && text.contains("Invalid source language operand: 10"))
        || (text.contains("eglInitialize") && text.contains("DRI2: failed to load driver"))
}

/// Whether the environment asks for validation: `WGPU_VALIDATION` set to
/// anything but `0`, the rule of wgpu's `InstanceFlags::with_env`.
pub fn requested() -> bool {
    std::env::var("WGPU_VALIDATION").is_ok_and(|v| v != "0")
}

/// Installs the logger before an instance is created, when validation is
/// asked for; an error when the program already has another logger (its
/// messages would go there, unseen by the gate).
pub(crate) fn install() -> Result<(), String> {
    static INSTALLED: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    INSTALLED
        .get_or_init(|| {
            log::set_logger(&SINK).map_err(|_| {
                "WGPU_VALIDATION is set, but this program already has a logger, which would take the validation layer's messages".to_string()
            })?;
            // Debug, so that wgpu's note that the layer is missing arrives;
            // only wgpu-hal's records are kept, and only error and warning
            // severities (the debug messenger's mask follows this level).
            log::set_max_level(log::LevelFilter::Debug);
            Ok(())
        })
        .clone()
}

/// The messages reported since the process started, as (errors,
/// warnings): what `check` prints under validation, so that a clean run
/// says it was watched.
pub fn seen() -> (u64, u64) {
    *SINK.seen.lock().unwrap_or_else(|p| p.into_inner())
}

/// Whether wgpu said that the layer asked for was not there.
pub(crate) fn layer_missing() -> bool {
    *SINK.layer_missing.lock().unwrap_or_else(|p| p.into_inner())
}

/// The messages since the last call.
pub fn take() -> Vec<LayerMessage> {
    let all = std::mem::take(&mut *SINK.messages.lock().unwrap_or_else(|p| p.into_inner()));
    all.into_iter().filter(|m| !m.dropped).collect()
}

/// The first error-severity message since the last call (warnings, such as
/// best-practices advice, are dropped).
pub(crate) fn take_first_error() -> Option<String> {
    take().into_iter().find(|m| m.error).map(|m| m.text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use log::Log;

    #[test]
    fn a_message_gathers_the_lines_logged_after_it() {
        let sink = Sink {
            messages: Mutex::new(Vec::new()),
            layer_missing: Mutex::new(false),
            seen: Mutex::new((0, 0)),
        };
        let record = |level, target: &'static str, text: &'static str| {
            sink.log(
                &log::Record::builder()
                    .level(level)
                    .target(target)
                    .args(format_args!("{text}"))
                    .build(),
            )
        };
        record(
            log::Level::Warn,
            "wgpu_hal::vulkan::instance",
            "BestPractices advice",
        );
        record(
            log::Level::Error,
            "wgpu_hal::vulkan::instance",
            "VALIDATION [SYNC-HAZARD-READ-AFTER-WRITE (0x1)]",
        );
        record(
            log::Level::Error,
            "wgpu_hal::vulkan::instance",
            "\tobjects: (type: PIPELINE, hndl: 0x1, name: tonegate.sphere)",
        );
        record(log::Level::Error, "tonegate::server", "not the layer's");
        record(
            log::Level::Error,
            "wgpu_hal::vulkan::instance",
            "VALIDATION [UNASSIGNED-CoreValidation-Shader-InconsistentSpirv (0x6bbb14)] SPIR-V module not valid: Invalid source language operand: 10",
        );
        record(
            log::Level::Debug,
            "wgpu_hal::vulkan::instance",
            "InstanceFlags::VALIDATION requested, but unable to find layer: VK_LAYER_KHRONOS_validation",
        );
        record(
            log::Level::Error,
            "wgpu_hal::vulkan::instance",
            "\tobjects: (type: DEVICE, hndl: 0x2, name: ?)",
        );
        let v: Vec<LayerMessage> = sink
            .messages
            .lock()
            .unwrap()
            .iter()
            .filter(|m| !m.dropped)
            .cloned()
            .collect();
        assert_eq!(v.len(), 2, "{v:?}");
        assert!(
            !v[1].text.contains("0x2"),
            "the dropped message's objects went with it"
        );
        assert!(!v[0].error);
        assert!(v[1].error);
        assert!(v[1].text.contains("SYNC-HAZARD") && v[1].text.contains("tonegate.sphere"));
        assert!(*sink.layer_missing.lock().unwrap());
        assert_eq!(
            *sink.seen.lock().unwrap(),
            (1, 1),
            "the false one is not counted"
        );
    }
}
