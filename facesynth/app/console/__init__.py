"""``facesynth console``: the rig console in the browser, for bringing up one head.

Modules: :mod:`.rig` (the pure core: jog targets, the draft profile's edits), :mod:`.profile_file`
(a profile as TOML, saved atomically with a backup), :mod:`.protocol` (the page's messages),
:mod:`.outbox` (an open page and what it is sent), :mod:`.session` (the console on the bus: C
in-process, commands, what the rig reports), :mod:`.calibration` (the performer calibration
with the page watching), :mod:`.server` (the aiohttp server: page, WebSocket, token, lock,
origin checks), :mod:`.arguments` and :mod:`.command` (the sub-command).
"""
