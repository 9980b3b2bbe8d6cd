//! catmull_rom
