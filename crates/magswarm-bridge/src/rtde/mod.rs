//! RTDE (Universal Robots Real-Time Data Exchange): wire format, client, emulated server.

pub mod client;
pub mod proto;
pub mod server;

pub use client::{ControllerVersion, Recipe, RobotState, RtdeClient, RtdeError, UrLink};
