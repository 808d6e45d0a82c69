//! Visual grasp prototypes (Sweeney 2011, ch. 6).
#![warn(missing_docs)]
