"""What the smart serial-bus servo drivers share (``dynamixel``, ``feetech``): µs to native
positions (:mod:`.native`), the vendor SDK on a bus thread (:mod:`.worker`, :mod:`.sdk_port`),
bus time from bytes (:mod:`.budget`), the packets of every frame built and parsed here
(:mod:`.wire`), the model checks (:mod:`.models`) and the async driver (:mod:`.driver`)."""
