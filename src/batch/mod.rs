//! Batch (in progress).
