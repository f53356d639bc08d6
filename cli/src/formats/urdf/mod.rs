//! URDF files (plain URDF, xacro expanded): reading the serial chain between two links
//! ([`parse`], [`chain`]), its conversion to the modified DH model of docs/formats.md "Kinematic model"
//! ([`mdh`]) and the calibrated joint origins written back into the original text
//! ([`splice`]). docs/formats.md, "import --urdf" and "export", says what goes where.

pub mod chain;
pub mod mdh;
pub mod parse;
pub mod splice;
