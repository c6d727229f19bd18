//! Errors of the robot models: URDF parsing, tree building and kinematic queries.
//!
//! Every variant names the file (or robot), the element or query, and what was expected,
//! so that a user with a broken URDF knows where to look.

use std::fmt;

/// Result alias of this module's fallible operations.
pub type RobotResult<T> = Result<T, RobotError>;

/// What went wrong while loading a robot description or querying its kinematics.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RobotError {
    /// The file could not be read.
    #[error("{file}: cannot read the URDF file: {source}")]
    Io {
        /// The file that was asked for.
        file: String,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// The text is not well-formed XML.
    #[error("{file}: not well-formed XML at line {line}, column {column}: {message}")]
    Xml {
        /// File name used in messages.
        file: String,
        /// 1-based line of the problem, as reported by the XML parser.
        line: u32,
        /// 1-based column of the problem.
        column: u32,
        /// The parser's reason.
        message: String,
    },
    /// An element is present but wrong: a bad number, a missing attribute, an unknown type ...
    #[error("{file}: {element}: {message}")]
    Invalid {
        /// File name used in messages.
        file: String,
        /// The element, e.g. `<joint name="elbow"> <origin xyz>`.
        element: String,
        /// What was found and what was expected.
        message: String,
    },
    /// An element of a URDF file is present but wrong (a bad number, a missing attribute, an
    /// unknown type …), at a line of the file.
    #[error("{file}:{line}: {element}: {message}")]
    InvalidElement {
        /// File name used in messages.
        file: String,
        /// The 1-based line the element starts on.
        line: u32,
        /// The element, e.g. `<joint name="elbow"> <origin> @xyz`.
        element: String,
        /// What was found and what was expected.
        message: String,
    },
    /// A joint names a link that the file does not declare.
    #[error("{file}:{line}: <joint name=\"{joint}\">: unknown {role} link \"{link}\" (expected the name of a declared <link>)")]
    UnknownLink {
        /// File name used in messages.
        file: String,
        /// The 1-based line of the joint.
        line: u32,
        /// The joint that refers to the link.
        joint: String,
        /// `"parent"` or `"child"`.
        role: &'static str,
        /// The undeclared link name.
        link: String,
    },
    /// The joints connect links in a loop; a URDF must be a tree.
    #[error("{file}: the joints form a cycle through links {}; a URDF must describe a tree", LinkList(.links))]
    Cycle {
        /// File name used in messages.
        file: String,
        /// Links on the cycle, in order.
        links: Vec<String>,
    },
    /// More than one link has no parent joint.
    #[error("{file}: {} root links ({}); expected exactly one link that is no joint's child", .roots.len(), LinkList(.roots))]
    MultipleRoots {
        /// File name used in messages.
        file: String,
        /// Every link without a parent joint.
        roots: Vec<String>,
    },
    /// urdf-rs refused the (already validated and normalised) text.
    #[error("{file}: urdf-rs could not read the file: {message}")]
    UrdfRs {
        /// File name used in messages.
        file: String,
        /// urdf-rs's message.
        message: String,
    },
    /// [`crate::Robot::builtin`] was given a name it does not know.
    #[error("unknown built-in robot \"{name}\"; expected one of: {}", .available.join(", "))]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// The names that exist.
        available: Vec<&'static str>,
    },
    /// A kinematic query named a link that the robot does not have.
    #[error("robot \"{robot}\": no link named \"{link}\"")]
    NoSuchLink {
        /// The robot's name.
        robot: String,
        /// The link asked for.
        link: String,
    },
    /// `chain(base, tip)` with a tip that is not below the base.
    #[error("robot \"{robot}\": link \"{tip}\" is not a descendant of link \"{base}\", so they do not bound a chain")]
    NotAChain {
        /// The robot's name.
        robot: String,
        /// The requested base link.
        base: String,
        /// The requested tip link.
        tip: String,
    },
    /// A configuration vector of the wrong length.
    #[error("{what}: expected {expected} joint values, got {got}")]
    WrongDof {
        /// The call that received the vector.
        what: String,
        /// Number of values needed.
        expected: usize,
        /// Number of values given.
        got: usize,
    },
}

/// Displays a list of link names as `"a", "b", "c"`.
struct LinkList<'a>(&'a [String]);

impl fmt::Display for LinkList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, name) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "\"{name}\"")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_file_element_and_expectation() {
        let e = RobotError::MultipleRoots {
            file: "a.urdf".into(),
            roots: vec!["base".into(), "stray".into()],
        };
        assert_eq!(
            e.to_string(),
            "a.urdf: 2 root links (\"base\", \"stray\"); expected exactly one link that is no joint's child"
        );
        let e = RobotError::UnknownLink {
            file: "b.urdf".into(),
            line: 7,
            joint: "j1".into(),
            role: "parent",
            link: "nowhere".into(),
        };
        assert!(e
            .to_string()
            .starts_with("b.urdf:7: <joint name=\"j1\">: unknown parent link \"nowhere\""));
    }

    #[test]
    fn error_is_send_sync() {
        fn check<T: Send + Sync + 'static>() {}
        check::<RobotError>();
    }
}
