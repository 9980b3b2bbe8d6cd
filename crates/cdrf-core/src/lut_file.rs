//! lut_file
