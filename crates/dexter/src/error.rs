//! The one error type of the robot side.

use control_basis::hardware::HardwareError;

/// Invalid use of the robot side or a failing device — never a skill's outcome (a grasp that does
/// not converge is an [`schema::ActionOutcome`], not an error).
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    /// A value is not valid (wrong size, not finite, unknown name).
    #[error("{context}: {field}: {message}")]
    Invalid {
        /// Where (`<vision>`, `<camera>`, `binding`).
        context: &'static str,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// The robot model lacks something the skills need, or a kinematics call failed.
    #[error(transparent)]
    Model(#[from] control_basis::CbError),
    /// The hardware failed.
    #[error(transparent)]
    Hardware(#[from] HardwareError),
    /// An arm cannot be put where a skill needs it (parking, IK).
    #[error("{0}")]
    Unreachable(String),
    /// An executive binding the robot cannot carry out (no arm, no place, no object).
    #[error("binding of `{action}`: {message}")]
    Binding {
        /// The abstract action.
        action: String,
        /// What is missing.
        message: String,
    },
    /// The schema library, the executive or the procedural model failed (an unknown schema, a
    /// model that cannot predict).
    #[error(transparent)]
    Schema(#[from] schema::SchemaError),
}

impl RobotError {
    pub(crate) fn invalid(context: &'static str, field: &str, message: impl Into<String>) -> Self {
        RobotError::Invalid {
            context,
            field: field.to_string(),
            message: message.into(),
        }
    }
}
