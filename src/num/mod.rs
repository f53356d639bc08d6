//! **Numbers**: the scalar every algorithm is generic over, a cheap `f32` sine/cosine and the
//! dense symmetric linear algebra of identification and planning, all on fixed storage.

pub mod linalg;
pub mod real;
pub mod trig;
