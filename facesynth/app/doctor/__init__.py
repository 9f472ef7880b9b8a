"""``facesynth doctor``: what this host can run and what to fix, one line per finding.

One module per check family, each a pure ``*_findings`` function over what a small shell
looked at: :mod:`.cameras`, :mod:`.serial_ports` (with the read-only board questions of
:mod:`.boards`), :mod:`.firmware_check`, :mod:`.router`, :mod:`.outputs`, :mod:`.named`
(profiles and calibrations the graph reads), :mod:`.extras`. :mod:`.needs` reads what a graph
needs; :mod:`.report` turns findings into lines and a verdict; :mod:`.command` is the CLI.
"""
