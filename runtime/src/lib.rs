//! cnc402-runtime: the cycle controller. A program goes through the interpreter and the
//! planner (outside the loop, running ahead) into a fixed-capacity ring of planned moves; the
//! loop ticks the interpolator and exchanges setpoints for feedback with the drives once per
//! period, and sends one status record per tick out through a second ring. The same loop runs
//! in virtual time (as fast as the CPU allows) or in real time on its own thread.

// NcError (lang's) is large; it ends a run, outside the loop, so its size costs nothing.
#![allow(clippy::result_large_err)]

pub mod channel_set;
pub mod channels;
pub mod controller;
pub mod feeder;
pub mod link;
pub mod machine_io;
pub mod master_link;
pub mod matching;
pub mod operator;
pub mod path_figures;
pub mod plot;
pub mod program_stop;
pub mod recorder;
pub mod report;
pub mod ring;
pub mod rt;
pub mod run;
pub mod sim_machine;
pub mod socket_machine;
pub mod status;
pub mod sync;
#[cfg(any(test, feature = "testing"))]
pub mod testing;

pub use controller::{CycleController, Step};
pub use feeder::ProgramInput;
pub use link::{DriveFeedback, DriveLink, DriveStop, FaultPlan, Startup, StopCause};
pub use master_link::{CycleBus, LinkTimeouts, MasterLink};
pub use plot::{write_channels_plot, write_plot};
pub use program_stop::{AtStop, StopDecision, StopGate, StopPolicy, StopRecord};
pub use report::RunReport;
pub use run::{
    ChannelRun, ChannelsReport, Progress, RunError, RunOptions, StatsSample, Timing, make_link,
    run_channels, run_input, run_program,
};
pub use sim_machine::{SimFault, SimFaultPlan, SimLink, SimMachine};
pub use socket_machine::{SocketLink, SocketMachine};
pub use status::{Outcome, Phase, Status};
