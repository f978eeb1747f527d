//! Universal Robots e-Series: the arm behind the [`crate::robot::Robot`] trait
//! ([`UrRobot`]: RTDE link, dashboard, servo program), the dashboard client and the URScript
//! servo program. The RTDE protocol itself is in [`crate::rtde`].

pub mod arm;
pub mod dashboard;
pub mod script;

use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

pub use arm::UrRobot;
pub use dashboard::Dashboard;
pub use script::{upload_script, ServoScript};

/// Errors of the dashboard and secondary-interface clients.
#[derive(Debug, thiserror::Error)]
pub enum UrError {
    /// The address does not resolve.
    #[error("{what} {addr}: {message}")]
    Address {
        /// Which interface.
        what: &'static str,
        /// host:port.
        addr: String,
        /// Why.
        message: String,
    },
    /// A socket operation failed.
    #[error("{what}: {source}")]
    Io {
        /// Interface, address and operation.
        what: String,
        /// The error.
        source: std::io::Error,
    },
    /// The server closed the connection.
    #[error("dashboard {addr}: closed on {on:?}")]
    Closed {
        /// host:port.
        addr: String,
        /// The command it closed on.
        on: String,
    },
    /// A command the bridge never sends (unlocking a protective stop).
    #[error("{0}")]
    Refused(String),
    /// The robot did not come up.
    #[error("{0}")]
    NotReady(String),
    /// The arm's RTDE link.
    #[error(transparent)]
    Rtde(#[from] crate::rtde::RtdeError),
    /// The arm is in a fault state (e.g. a protective stop), or faulted while starting.
    #[error("{name}: {0}", name = .0.name())]
    Fault(crate::safety::Fault),
}

/// Connect to `host:port` (interface `what`) within `timeout`.
pub(crate) fn connect(
    what: &'static str,
    host: &str,
    port: u16,
    timeout: Duration,
) -> Result<(TcpStream, String), UrError> {
    let addr = format!("{host}:{port}");
    let bad = |message: String| UrError::Address {
        what,
        addr: addr.clone(),
        message,
    };
    let sa = addr
        .to_socket_addrs()
        .map_err(|e| bad(e.to_string()))?
        .next()
        .ok_or_else(|| bad("no address".into()))?;
    let s = TcpStream::connect_timeout(&sa, timeout).map_err(|e| UrError::Io {
        what: format!("{what} {addr}: connecting"),
        source: e,
    })?;
    Ok((s, addr))
}
