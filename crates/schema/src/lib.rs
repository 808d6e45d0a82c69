//! Sensorimotor schemas (Sweeney 2011, ch. 3-5).
#![warn(missing_docs)]
