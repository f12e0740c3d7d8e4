//! Integration tests, compiled as one binary.

mod activation;
mod cli;
mod common;
mod contact_floor;
mod contact_pair;
mod contact_reach;
mod coupled_constraints;
mod derivatives;
mod dynamics_tree;
mod extremes;
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
mod fmi_bad_calls;
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
mod fmi_bad_files;
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
mod fmi_bad_values;
#[cfg(all(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    target_os = "linux"
))]
mod fmi_fuzz;
mod fmi_load;
mod fmu_documentation;
mod fmu_scene;
mod geometry_meshes;
mod geometry_pruning;
mod geometry_shapes;
mod geometry_ssdf;
mod golden_model_description;
mod host_fmi_crate;
mod integrators;
mod layers;
mod long_run;
mod mesh_hulls;
mod mjcf_attach;
mod mjcf_compile;
mod mocap;
mod scene_eps1;
mod scene_errors;
mod scene_spacing;
mod scene_sphere_drop;
mod scenes_dynamics;
mod sim_facade;
