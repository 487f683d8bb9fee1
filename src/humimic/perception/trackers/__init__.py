"""Tracker stages of the ``trackers:`` scenario section, one sub-package per ``kind``
(``perception/trackers/<kind>/``: config, pure maths, tracker class, stage, scores); shared
pieces in :mod:`.common`. :mod:`.config` holds the union of the kinds' configs, :mod:`.build`
builds the stages."""
