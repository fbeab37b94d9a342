//! Choosing a burn device by name, for the commands that can run on a GPU (`cargo xtask
//! bench model --device NAME`).
//!
//! The CPU `flex` backend is always built. The GPU backend is the Cargo feature `gpu`
//! (wgpu on Vulkan), off by default and never built in CI. burn's CUDA backend is not
//! offered: its build script downloads an LLVM bundle (`tracel-llvm-bundler`), which fails
//! on machines without internet access such as these. A name whose backend this build
//! leaves out is an error that says what to do.

use burn::tensor::Device;

use crate::error::ModelError;

/// The device names [`device_named`] knows (`vulkan` needs the `gpu` feature).
pub const DEVICE_NAMES: [&str; 2] = ["cpu", "vulkan"];

/// The burn device called `name`: `cpu` (flex) or `vulkan` (the best adapter wgpu finds on
/// Vulkan; feature `gpu`). `cuda` is refused with the reason.
pub fn device_named(name: &str) -> Result<Device, ModelError> {
    match name {
        "cpu" | "flex" => Ok(Device::flex()),
        #[cfg(feature = "gpu")]
        "vulkan" | "wgpu" => Ok(Device::vulkan(burn::tensor::DeviceKind::DefaultDevice)),
        #[cfg(not(feature = "gpu"))]
        "vulkan" | "wgpu" => Err(ModelError::Device {
            name: name.to_string(),
            message: "this build has no GPU backend; build with the Cargo feature `gpu`, e.g. \
                      `cargo run --release -p xtask --features gpu -- bench model --device vulkan`"
                .into(),
        }),
        "cuda" => Err(ModelError::Device {
            name: name.to_string(),
            message: "burn's CUDA backend is not built: its build script downloads LLVM, which fails \
                      offline; use `vulkan` (Cargo feature `gpu`) on an NVIDIA GPU"
                .into(),
        }),
        _ => Err(ModelError::Device {
            name: name.to_string(),
            message: format!("unknown device; use one of {}", DEVICE_NAMES.join(", ")),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_is_always_there_and_unknown_names_are_refused() {
        assert_eq!(device_named("cpu").unwrap(), Device::flex());
        let e = device_named("tpu").unwrap_err().to_string();
        assert!(e.contains("unknown device") && e.contains("vulkan"), "{e}");
        let e = device_named("cuda").unwrap_err().to_string();
        assert!(e.contains("vulkan"), "{e}");
        #[cfg(not(feature = "gpu"))]
        {
            let e = device_named("vulkan").unwrap_err().to_string();
            assert!(e.contains("--features gpu"), "{e}");
        }
    }
}
