//! The cloth simulator of the paper (section 4): mass-spring cloth, implicit
//! Euler with filtered conjugate gradients, constraint-filtered collision response.
