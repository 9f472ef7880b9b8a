"""A simulated head babbled and learned in process, for ``bench robot --learn-poses`` and tests.

:func:`babble_simhead` babbles uniform random poses of a simulated head (a neutral every
``neutral_every`` poses) with the in-process babbler of :mod:`facesynth.app.learn.inprocess`
(each pose settled, rendered, tracked with the ``full`` model and read by F with the head at
rest as the neutral: what ``facesynth learn`` sees through a camera, without real time or a
serial port). :func:`learn_simhead` fits a learned profile on such a babbling
(:func:`facesynth.app.learn.fit.fit_learned_profile`, the ``[learn]`` extra) with the hardware
profile that has the head's servos (:func:`hardware_for`). The learned profile's own record of
what the robot moved while babbling is what ``bench robot`` leads with
(:func:`babbled_features`).
"""

from __future__ import annotations

import msgspec

from facesynth.app.learn.dataset import BabbleSet
from facesynth.app.simhead import HeadConfig, load_head
from facesynth.runtime.profiles import Profile, available_profiles, load_profile
from facesynth.runtime.profiles.learned import shown_inputs

__all__ = [
    "HARDWARE",
    "LEARNED_NAME",
    "MIN_POSES",
    "babble_simhead",
    "babbled_features",
    "hardware_for",
    "learn_simhead",
]

#: The fewest poses a fit is asked for (it holds 20 % out and needs 10 different poses).
MIN_POSES = 60
#: The hardware profile of the 16-servo heads (the bundled simhead16* and every ``seed:N``).
HARDWARE = "head16_hardware"
#: The name of a profile learned in process (one column per head in ``bench robot``).
LEARNED_NAME = "learned"


def babble_simhead(
    profile: Profile,
    poses: int,
    *,
    head: str = "simhead16",
    seed: int = 0,
    neutral_every: int = 20,
    frames: int = 2,
) -> BabbleSet:
    """``poses`` uniform random poses (normalized units, seeded) of the simulated head
    ``head`` (a name as :func:`~facesynth.app.simhead.load_head` takes it), each tracked for
    ``frames`` frames (the tracker follows its last face: more frames, less hysteresis)."""
    from facesynth.app.learn.inprocess import SimBabbler, babble, uniform_poses

    plan = uniform_poses(len(profile.servos), poses, seed, neutral_every)
    return babble(SimBabbler(profile, head, frames), plan)


def hardware_for(head: HeadConfig) -> Profile:
    """The hardware profile whose servos are the head's actuators (same names on the same
    channels): head16_hardware for the 16-servo heads, head18_lids_hardware for a head with
    lids, …; ``ValueError`` when none has them."""
    wanted = {(a.name, a.channel) for a in head.actuators}
    names = [HARDWARE] + [
        name
        for name in available_profiles(hardware=True)
        if name.endswith("_hardware") and name != HARDWARE
    ]
    for name in names:
        profile = load_profile(name)
        if {(s.name, s.channel) for s in profile.servos} == wanted:
            return profile
    raise ValueError(
        f"head {head.name}: no hardware profile has its servos (names and channels) to babble it"
    )


def learn_simhead(head: str, poses: int, *, seed: int = 0) -> Profile:
    """A profile learned in process for the simulated head ``head`` (a name as
    :func:`~facesynth.app.simhead.load_head` takes it) from ``poses`` babbled poses, on
    :func:`hardware_for` the head, with the fit's default options, named
    :data:`LEARNED_NAME`; ``ValueError`` (one line) when it cannot be fitted (fewer than
    :data:`MIN_POSES` poses, no face, no hardware profile, scikit-learn missing)."""
    from facesynth.app.learn.fit import fit_learned_profile

    if poses < MIN_POSES:
        raise ValueError(f"--learn-poses must be at least {MIN_POSES} (got {poses})")
    hardware = hardware_for(load_head(head))
    babble = babble_simhead(hardware, poses, head=head, seed=seed)
    fitted = fit_learned_profile(babble, hardware)
    return msgspec.structs.replace(fitted, name=LEARNED_NAME)


def babbled_features(profile: Profile) -> frozenset[str]:
    """What the robot moved while babbling, as a learned profile's fit recorded it: the inputs
    it fitted whose spread the commands explain (the features T shows,
    :func:`~facesynth.runtime.profiles.learned.shown_inputs`)."""
    if profile.learned is None:
        raise ValueError(f"profile {profile.name} is not learned: it has no babbling")
    return frozenset(shown_inputs(profile.learned))
