//! Binding indices of the frame's resources in bind group 0: the pipeline
//! layout, the bind group and the shader (through the generated prelude)
//! all take them from here.

pub const PARAMS: u32 = 0;
pub const VOLUME: u32 = 1;
pub const NORMALS: u32 = 2;
pub const LUT: u32 = 3;
pub const IMAGE: u32 = 4;
pub const STATS: u32 = 5;
pub const VOLUME_SAMPLER: u32 = 6;
pub const LINEAR_SAMPLER: u32 = 7;
pub const RAY_STATE: u32 = 8;
pub const RAY_DONE: u32 = 9;
pub const OCCUPANCY: u32 = 10;
pub const PREINT: u32 = 11;
pub const DEPTH_IN: u32 = 12;

/// Every binding with the name the shader gives its index (`BINDING_<name>`).
pub const ALL: [(&str, u32); 13] = [
    ("PARAMS", PARAMS),
    ("VOLUME", VOLUME),
    ("NORMALS", NORMALS),
    ("LUT", LUT),
    ("IMAGE", IMAGE),
    ("STATS", STATS),
    ("VOLUME_SAMPLER", VOLUME_SAMPLER),
    ("LINEAR_SAMPLER", LINEAR_SAMPLER),
    ("RAY_STATE", RAY_STATE),
    ("RAY_DONE", RAY_DONE),
    ("OCCUPANCY", OCCUPANCY),
    ("PREINT", PREINT),
    ("DEPTH_IN", DEPTH_IN),
];
