//! File input/output (in progress).
