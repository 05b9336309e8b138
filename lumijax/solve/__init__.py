"""Radiosity solves: ``(I − ρF) B = B₀`` for many right-hand sides (see ``docs/radiosity.md``)."""

from ._radiosity import (
    RadiositySolution as RadiositySolution,
    check_reflectance as check_reflectance,
    escaped_fraction as escaped_fraction,
    solve_radiosity as solve_radiosity,
)
