//! Choosing a burn device by name, for the commands that can run on a GPU (`cargo xtask
//! bench model --device NAME`).
//!
//! The CPU `flex` backend is always built. GPU backends are Cargo features, off by default
//! and never built in CI: `gpu` adds wgpu (Vulkan), `cuda` adds CubeCL's CUDA runtime. A
//! name whose backend this build leaves out is an error that names the feature to enable.

use burn::tensor::Device;

use crate::error::ModelError;

/// The device names [`device_named`] accepts, whether or not this build has their backend.
pub const DEVICE_NAMES: [&str; 3] = ["cpu", "vulkan", "cuda"];

/// The burn device called `name`: `cpu` (flex), `vulkan` (the best adapter wgpu finds on
/// Vulkan; feature `gpu`) or `cuda` (GPU 0; feature `cuda`).
pub fn device_named(name: &str) -> Result<Device, ModelError> {
    let missing = |feature: &str| ModelError::Device {
        name: name.to_string(),
        message: format!(
            "this build has no {name} backend; build with the Cargo feature `{feature}`, e.g. \
             `cargo run --release -p xtask --features {feature} -- bench model --device {name}`"
        ),
    };
    match name {
        "cpu" | "flex" => Ok(Device::flex()),
        #[cfg(feature = "gpu")]
        "vulkan" | "wgpu" => Ok(Device::vulkan(burn::tensor::DeviceKind::DefaultDevice)),
        #[cfg(not(feature = "gpu"))]
        "vulkan" | "wgpu" => Err(missing("gpu")),
        #[cfg(feature = "cuda")]
        "cuda" => Ok(Device::cuda(0)),
        #[cfg(not(feature = "cuda"))]
        "cuda" => Err(missing("cuda")),
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
        #[cfg(not(feature = "cuda"))]
        {
            let e = device_named("cuda").unwrap_err().to_string();
            assert!(e.contains("--features cuda"), "{e}");
        }
    }
}
