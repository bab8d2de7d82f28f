//! Chains (in progress).
