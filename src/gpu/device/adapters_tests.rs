//! The adapter choice on made-up adapter lists, and the flags that name it.

use super::*;
use crate::gpu::capability::gl_has_compute;
use wgpu::DeviceType::{Cpu, DiscreteGpu, IntegratedGpu};

fn found(list: &[(&str, wgpu::DeviceType)]) -> Vec<Candidate> {
    list.iter()
        .map(|&(name, device_type)| Candidate {
            name: name.into(),
            device_type,
            backend: wgpu::Backend::Vulkan,
            lacks: None,
        })
        .collect()
}

#[test]
fn the_default_is_the_software_rasterizer_and_names_the_hardware_it_skips() {
    let f = found(&[
        ("Intel(R) UHD 770", IntegratedGpu),
        ("NVIDIA H100 80GB HBM3", DiscreteGpu),
        ("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu),
    ]);
    let (i, why) = choose(&AdapterPick::Default, &f).unwrap();
    assert_eq!(i, 2);
    assert!(
        why.contains("NVIDIA H100") && why.contains("Intel"),
        "{why}"
    );
    assert!(why.contains("--adapter hardware"), "{why}");

    let (i, why) = choose(&AdapterPick::Hardware, &f).unwrap();
    assert_eq!(i, 1, "discrete before integrated: {why}");
    let (i, _) = choose(&AdapterPick::Name("intel".into()), &f).unwrap();
    assert_eq!(i, 0);
    let (i, _) = choose(&AdapterPick::Any, &f).unwrap();
    assert_eq!(i, 0);
}

#[test]
fn only_software_or_only_hardware() {
    let soft = found(&[("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu)]);
    let (i, why) = choose(&AdapterPick::Default, &soft).unwrap();
    assert_eq!(i, 0);
    assert!(why.contains("no hardware adapter found"), "{why}");
    let e = choose(&AdapterPick::Hardware, &soft).unwrap_err();
    assert!(e.to_string().contains("llvmpipe"), "{e}");

    let hard = found(&[("AMD Radeon", IntegratedGpu), ("NVIDIA", DiscreteGpu)]);
    let (i, why) = choose(&AdapterPick::Default, &hard).unwrap();
    assert_eq!(i, 0);
    assert!(why.contains("no software rasterizer"), "{why}");
    assert!(matches!(
        choose(&AdapterPick::Default, &[]),
        Err(GpuError::NoAdapter)
    ));
    let e = choose(&AdapterPick::Name("quadro".into()), &hard).unwrap_err();
    assert!(
        e.to_string()
            .contains("AMD Radeon (Vulkan), NVIDIA (Vulkan)"),
        "{e}"
    );
}

#[test]
fn the_default_prefers_llvmpipe_over_other_software_rasterizers() {
    // SwiftShader lists first once its driver is added; the bounds were
    // measured on llvmpipe, so the default must not drift to it.
    let f = found(&[
        ("SwiftShader Device (Subzero)", Cpu),
        ("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu),
    ]);
    let (i, _) = choose(&AdapterPick::Default, &f).unwrap();
    assert_eq!(i, 1);
    let (i, _) = choose(&AdapterPick::Name("swiftshader".into()), &f).unwrap();
    assert_eq!(i, 0);
    // Without llvmpipe, another software rasterizer rather than the first listed.
    let f = found(&[
        ("AMD Radeon", IntegratedGpu),
        ("SwiftShader Device (Subzero)", Cpu),
    ]);
    let (i, why) = choose(&AdapterPick::Default, &f).unwrap();
    assert_eq!(i, 1, "{why}");
    assert!(
        choose(&AdapterPick::Hardware, &f).unwrap().0 == 0,
        "SwiftShader is never hardware"
    );
}

#[test]
fn adapter_flags_name_a_backend_and_an_adapter() {
    let c: AdapterChoice = "gl:llvmpipe".parse().unwrap();
    assert_eq!(c.backend, BackendChoice::Gl);
    assert_eq!(c.pick, AdapterPick::Name("llvmpipe".into()));
    let c: AdapterChoice = "swiftshader".parse().unwrap();
    assert_eq!(
        c,
        AdapterChoice::new(AdapterPick::Name("swiftshader".into()))
    );
    let c: AdapterChoice = "vulkan:hardware".parse().unwrap();
    assert_eq!(c.pick, AdapterPick::Hardware);
    assert_eq!(c.backend, BackendChoice::Vulkan);
    // A colon that names no backend belongs to the name.
    let c: AdapterChoice = "Radeon:X".parse().unwrap();
    assert_eq!(c.pick, AdapterPick::Name("Radeon:X".into()));
    assert_eq!("DX12".parse::<BackendChoice>(), Ok(BackendChoice::Dx12));
    let e = "glide".parse::<BackendChoice>().unwrap_err();
    assert!(e.contains("glide") && e.contains("vulkan, gl"), "{e}");
}

#[test]
fn the_extra_drivers_are_absolute_manifest_paths() {
    for p in EXTRA_VULKAN_DRIVERS {
        assert!(p.starts_with('/') && p.ends_with(".json"), "{p}");
    }
    // Those listed as present are files.
    assert!(extra_vulkan_drivers().iter().all(|p| p.is_file()));
}

#[test]
fn an_adapter_without_compute_is_never_picked_and_a_pick_of_it_says_why() {
    let mut f = found(&[
        ("NVIDIA H200/PCIe/SSE2", DiscreteGpu),
        ("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu),
    ]);
    f[0].backend = wgpu::Backend::Gl;
    f[0].lacks = Some("no compute shaders, which every stage needs".into());
    // The default and `any` take the usable software rasterizer.
    let (i, _) = choose(&AdapterPick::Default, &f).expect("llvmpipe is usable");
    assert_eq!(i, 1);
    let (i, _) = choose(&AdapterPick::Any, &f).expect("llvmpipe is usable");
    assert_eq!(i, 1);
    // Asking for the hardware, or for it by name, is refused with the reason,
    // not "no adapter matches" and not a tonegate bug.
    for pick in [AdapterPick::Hardware, AdapterPick::Name("H200".into())] {
        let e = choose(&pick, &f).expect_err("the only hardware lacks compute");
        let text = e.to_string();
        assert!(
            matches!(e, GpuError::Unsupported { .. }),
            "{pick:?}: {text}"
        );
        assert!(
            text.contains("NVIDIA H200") && text.contains("no compute shaders"),
            "{text}"
        );
    }
}

#[test]
fn a_gl_version_string_says_whether_it_has_compute() {
    // NVIDIA 580.159.04 on an H200 (2026-11-27), and Mesa 22.3.6 here.
    assert!(!gl_has_compute("3.3.0 NVIDIA 580.159.04"));
    assert!(gl_has_compute("4.5 (Core Profile) Mesa 22.3.6"));
    assert!(gl_has_compute("4.6.0 NVIDIA 580.159.04"));
    assert!(gl_has_compute("4.3"));
    assert!(!gl_has_compute("4.2.0"));
    assert!(gl_has_compute("OpenGL ES 3.2 Mesa 22.3.6"));
    assert!(gl_has_compute("OpenGL ES 3.1"));
    assert!(!gl_has_compute("OpenGL ES 3.0 Mesa 22.3.6"));
    // No version in it: not refused on a guess.
    assert!(gl_has_compute(""));
}

#[test]
fn any_says_which_list_it_took_the_first_of() {
    let f = found(&[
        ("llvmpipe (LLVM 15.0.6, 256 bits)", Cpu),
        ("NVIDIA H200", DiscreteGpu),
    ]);
    let (i, why) = choose(&AdapterPick::Any, &f).unwrap();
    assert_eq!(i, 0);
    assert!(
        why.contains("the first the drivers list of llvmpipe"),
        "{why}"
    );
    assert!(
        why.contains("only for an adapter asked for by name"),
        "{why}"
    );
}
