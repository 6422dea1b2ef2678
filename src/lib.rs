//! Flockway
