//! Creates the compute pipeline of one WGSL file on the first Vulkan adapter, and nothing
//! else: the host side of the reproducer of a heap overflow in Mesa 22.3's lavapipe (Debian
//! 12's `mesa-vulkan-drivers` 22.3.6) during `vkCreateComputePipelines`. `run.sh` runs it
//! under valgrind on `kernel.wgsl` and on the same kernel with one binding changed.
//!
//! ```text
//! cargo run --release --example lavapipe_ubo_repro -- FILE.wgsl ENTRY_POINT
//! ```

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(file), Some(entry)) = (args.first(), args.get(1)) else {
        eprintln!("usage: lavapipe_ubo_repro FILE.wgsl ENTRY_POINT");
        std::process::exit(2);
    };
    let source = std::fs::read_to_string(file).unwrap_or_else(|e| {
        eprintln!("cannot read {file}: {e}");
        std::process::exit(2);
    });

    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))
        .expect("a Vulkan adapter");
    let info = adapter.get_info();
    let (device, _queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        // Brume's wavefront kernels bind up to 13 storage buffers.
        required_limits: wgpu::Limits {
            max_storage_buffers_per_shader_stage: 16,
            ..Default::default()
        },
        ..Default::default()
    }))
    .expect("a device");
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("repro"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let _pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("repro"),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    });
    if let Some(e) = pollster::block_on(scope.pop()) {
        eprintln!("{file}: {e}");
        std::process::exit(1);
    }
    println!(
        "{} ({}): pipeline of {entry} created",
        info.name, info.driver_info
    );
}
