"""The 52 ARKit-style blendshapes, in the order MediaPipe's blendshape model outputs them.

The order and spelling are MediaPipe's ``kBlendshapeNames``
(google-ai-edge/mediapipe, ``mediapipe/tasks/cc/vision/face_landmarker/face_blendshapes_graph.cc``):
``_neutral`` first, then the 51 ARKit ``ARFaceAnchor.BlendShapeLocation`` names in alphabetical
order. Each score is in [0, 1] (0 = not at all, 1 = fully). Left/right are the performer's own
(ARKit's convention): ``mouthSmileLeft`` is the performer's left lip corner, on the image's right
for an unmirrored camera.

P publishes them as the ``blendshapes52`` score set of ``Points`` (values in this order); F turns
each (except ``_neutral``) into the named feature ``bs_<name>`` (see
:mod:`facesynth.runtime.feature_names`).
"""

from __future__ import annotations

from typing import Final

BLENDSHAPES52: Final = "blendshapes52"

NAMES: Final[tuple[str, ...]] = (
    "_neutral",
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
    "cheekPuff",
    "cheekSquintLeft",
    "cheekSquintRight",
    "eyeBlinkLeft",
    "eyeBlinkRight",
    "eyeLookDownLeft",
    "eyeLookDownRight",
    "eyeLookInLeft",
    "eyeLookInRight",
    "eyeLookOutLeft",
    "eyeLookOutRight",
    "eyeLookUpLeft",
    "eyeLookUpRight",
    "eyeSquintLeft",
    "eyeSquintRight",
    "eyeWideLeft",
    "eyeWideRight",
    "jawForward",
    "jawLeft",
    "jawOpen",
    "jawRight",
    "mouthClose",
    "mouthDimpleLeft",
    "mouthDimpleRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthFunnel",
    "mouthLeft",
    "mouthLowerDownLeft",
    "mouthLowerDownRight",
    "mouthPressLeft",
    "mouthPressRight",
    "mouthPucker",
    "mouthRight",
    "mouthRollLower",
    "mouthRollUpper",
    "mouthShrugLower",
    "mouthShrugUpper",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthStretchLeft",
    "mouthStretchRight",
    "mouthUpperUpLeft",
    "mouthUpperUpRight",
    "noseSneerLeft",
    "noseSneerRight",
)
COUNT: Final = len(NAMES)
#: The 51 expression shapes (everything but ``_neutral``).
SHAPES: Final[tuple[str, ...]] = NAMES[1:]
INDEX: Final[dict[str, int]] = {name: i for i, name in enumerate(NAMES)}

assert COUNT == 52
