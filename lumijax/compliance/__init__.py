"""The quantities lighting standards ask for and a verdict per standard (docs/compliance.md):
cylindrical, semi-cylindrical and hemispherical illuminance, modelling, the EN 12464-1 grid
rule, maintenance (CIE 97:2005), energy (W/m², LENI per EN 15193-1), obtrusive light
(CIE 150:2017), each a JAX function of the per-network light and the dimmers."""

from ._energy import PowerModel as PowerModel, leni_kwh_per_m2 as leni_kwh_per_m2
from ._maintenance import (
    luminaire_maintenance_factor as luminaire_maintenance_factor,
    maintenance_factor as maintenance_factor,
)
from ._obtrusive import (
    intensity_toward as intensity_toward,
    reflected_upward_flux as reflected_upward_flux,
    sky_fraction as sky_fraction,
    upward_flux as upward_flux,
)
from ._sensors import (
    SensorLight as SensorLight,
    modelling_ratio as modelling_ratio,
    sensor_light as sensor_light,
)
from ._study_grids import sensor_grids as sensor_grids
from ._verdict import (
    Compliance as Compliance,
    ComplianceModel as ComplianceModel,
    Criterion as Criterion,
    compliance_model as compliance_model,
    evaluate_compliance as evaluate_compliance,
)
