//! The particle sensor of the paper (section 2): a few particles moving on the
//! surface that sense folds and gate the BVH traversal.
