"""A commented profile holding every field: the format's reference, checked valid by the tests."""

FORMAT_REFERENCE = """\
name = "robot"                 # required
description = ""
scheme = "ibug68"
mirror = false                 # true: the robot's right follows the performer's left
neutral_seconds = 1.0          # F: seconds of face used as neutral without a calibration
neutral_ramp_s = 0.5           # servos without max_speed: seconds back to neutral (linear)
                               # when the face is lost, and to catch up when it returns; 0 = jump
max_command_age_s = 0.25       # C drops commands older than this (0.02-5 s): a stalled or
                               # healed link's backlog is never executed

[smoothing]                    # One Euro filter per source signal; absent = no filtering
enabled = true
min_cutoff = 0.5               # Hz, > 0: cutoff at rest (lower = less jitter, more lag)
beta = 1.0                     # >= 0: cutoff rises by beta x speed (range units per second)
d_cutoff = 1.0                 # Hz, > 0: cutoff of the speed estimate

[[servos]]
name = "jaw"                   # unique
channel = 0                    # unique, >= 0
min_us = 1000                  # min_us <= neutral_us <= max_us, min_us < max_us, min_us >= 0
neutral_us = 1500
max_us = 2000
reversed = false               # swap the directions
points = [56, 57, 58]          # source: an ibug68 group (0..67) on Features.deltas ...
face_min = -0.06               # ... with its movement (IOD) at min_us / max_us: face_min < 0
face_max = 0.3                 #     < face_max (a calibration replaces them)
gain = 1.0                     # finite, non-zero: multiplies the source value
deadband = 0.0                 # >= 0, source units (IOD for points, scaled for named features)
max_speed = 2500               # µs/s, >= 0, 0 = unlimited
max_accel = 30000              # µs/s², >= 0, 0 = unlimited
smoothing = { beta = 0.5 }     # per-servo override of [smoothing] fields (enabled too)
angle = { min_us = 500, max_us = 2500, min_deg = 0, max_deg = 180 }  # pulse -> joint angle,
                               # linear (the default; min_us < max_us, min_deg != max_deg):
                               # what the ros2 driver sends, in radians
bus_id = 1                     # smart bus servos (dynamixel, feetech): the servo's id,
                               # 0..252, unique (default channel + 1)
model = "XL430-W250"           # the model the bus must answer with (default: any it knows)
native_min = 1024              # native positions at min_us / max_us, both or neither
native_max = 3072              # (default: through angle, 1500 us = the model's centre)

[[servos]]
name = "brow_raise"
channel = 1
min_us = 1000
neutral_us = 1000
max_us = 2000
feature = "brow_raise_inner_right"   # source: a named feature (0 neutral, +-1 calibrated extremes)
max_speed = 3000

[[servos]]
name = "brow_lower"
channel = 2
min_us = 1000
neutral_us = 1000
max_us = 2000
mix = { brow_lower_right = 1.0, brow_raise_outer_right = -0.5 }  # source: a weighted sum
max_speed = 3000               # (a mix may weigh blendshapes too: { mouthSmileRight = 1.0 })

[[servos]]
name = "smile"
channel = 3
min_us = 0
neutral_us = 0
max_us = 1000
blendshape = "mouthSmileRight" # source: an ARKit blendshape (--model full), scaled like features
one_sided = true               # below the performer's neutral reads as neutral, never past it

[[servos]]                     # no source: a hardware-only servo (channel, limits, speeds),
name = "lid"                   # what facesynth learn and the control interface need; the
channel = 4                    # translator drives it only from a learned profile (NAME.learned,
min_us = 1000                  # written by facesynth learn; it ignores reversed: the learned
neutral_us = 1500              # model knows the wiring)
max_us = 2000
max_speed = 3000

[bus]                          # smart servo bus (dynamixel, feetech); their options win
baud = 1000000                 # the bus's baud rate (default: the driver's, see its --help)
protocol = 2                   # Dynamixel protocol 1 (AX, MX) or 2 (X); default from the models

[[safety.exclusive]]           # never two of these servos beyond threshold of their travel
servos = ["brow_raise", "brow_lower"]
threshold = 0.8                # in (0, 1]
"""
