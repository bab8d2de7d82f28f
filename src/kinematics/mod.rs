//! Kinematics (in progress).
