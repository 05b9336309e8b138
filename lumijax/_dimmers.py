"""A network's dimmer: its default and its range, for the config schema and for the rerun that
reads a study file without the schema (``lumijax._recorded``)."""

#: ``[networks.NAME] dimmer`` where a study gives none: full output (the photometry's flux)
DEFAULT = 1.0
#: the closed range of a dimmer: off to full output
LOW, HIGH = 0.0, 1.0
