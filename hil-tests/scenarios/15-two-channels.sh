#!/usr/bin/env bash
# Two channels on one bus (issue 15): channel 0 runs X Y Z, channel 1 runs U V W
# (machine-vcan-two-channel.toml: seven drives, 2000 us period), both in the one loop with one
# master and one SYNC, meeting at a Fanuc wait M code (M100 P12). Both programs end ok at
# their programmed final positions, every drive (nodes 1-7) reached OPERATION ENABLED and never faulted, no protocol errors. The in-process
# equivalent is tests/channels_cli.rs::hil_15_two_channels_in_process.
source "$HIL_REPO/hil-tests/scenarios/common.bash"
# A guard against a hang, not a timing check (a few seconds of program time).
RUN_LIMIT=200
RUN_EXTRA="--channel 1=$SC_DIR/programs/two-channel-sub.nc"
scenario_run "$SC_DIR/machine-vcan-two-channel.toml" "$SC_DIR/programs/two-channel-main.nc"
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    'protocol_errors.pdo_length_errors == 0' 'drives.*.faults_entered == 0' \
    'drives.*.reached_operation_enabled == true' \
    -- 'ok == true' 'channels.0.ok == true' 'channels.1.ok == true' \
    'channels.0.report.axes.X.final_position > 39.999' 'channels.0.report.axes.X.final_position < 40.001' \
    'channels.0.report.axes.Y.final_position > 19.999' 'channels.0.report.axes.Y.final_position < 20.001' \
    'channels.1.report.axes.U.final_position > 24.999' 'channels.1.report.axes.U.final_position < 25.001' \
    'channels.1.report.axes.W.final_position > -0.001' 'channels.1.report.axes.W.final_position < 0.001'
scenario_end "$COMMON_FIGURES_DRIVE" \
    "channel 0 {channels.0.report.program_time_s:.1} s, channel 1 {channels.1.report.program_time_s:.1} s, bus {channels.0.report.bus.frames} frames {channels.0.report.bus.load_percent:.1} %"
