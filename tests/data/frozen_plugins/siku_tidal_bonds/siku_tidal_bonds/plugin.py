"""siku hooks of siku-tidal-bonds."""
from siku_core import hookimpl

from .beam import BondedBeam
from .tide import TidalCurrent


@hookimpl
def siku_register_contact_laws():
    return [BondedBeam]


@hookimpl
def siku_register_forcing_sources():
    return [TidalCurrent]
