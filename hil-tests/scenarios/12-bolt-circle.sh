#!/usr/bin/env bash
# Bolt-circle drilling (examples/bolt-circle-drilling.nc, G81 and G83 with the spindle
# running): the run ends ok at the programmed final position, every drive still enabled, no
# protocol errors; simdrive sees Z+C windows only with the spindle already running (reported,
# not judged as taps).
source "$HIL_REPO/hil-tests/scenarios/common.bash"
# A guard against a hang, not a timing check: the program is 54.5 s of program time, which
# a loaded guest runs at half speed or less (the suite gives each script 300 s, and
# scenario_run keeps 50 s of it for simdrive's start and stop: 250 s at most).
RUN_LIMIT=250
scenario_run "$SC_DIR/machine-vcan.toml" examples/bolt-circle-drilling.nc
expect_rc "cnc402 run" "$RUN_RC" 0
expect_rc simdrive "$DRIVE_RC" 0
scenario_check 'ok == true' 'tap_windows == 0' 'protocol_errors.unexpected_frames == 0' 'protocol_errors.unaddressed_frames == 0' \
    'protocol_errors.pdo_length_errors == 0' 'drives.*.faults_entered == 0' \
    'drives.*.reached_operation_enabled == true' \
    -- 'ok == true' 'axes.X.final_position > 69.999' 'axes.X.final_position < 70.001' \
    'axes.Z.final_position > 49.999' 'axes.Z.final_position < 50.001'
scenario_end "spindle windows {spindle_windows}; $COMMON_FIGURES_DRIVE" \
    "program {program_time_s:.1} s in {wall_time_s:.1} s, bus {bus.frames} frames {bus.load_percent:.1} %; $COMMON_FIGURES_RUN"
