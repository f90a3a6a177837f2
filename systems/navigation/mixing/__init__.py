"""Mixing of odometric and inertial estimates, Seyr & Jakubek §IV-D, with the tyre model's extensions.

- parameters.py: MixingParameters;
- weights.py: the switches C1 S(12), C2 S(13), C3 S(14) and their blocks MixerC1, MixerC2C3;
- tyre_curve.py: the tyre curve the mixer believes (side slip, longitudinal creep, utilisation);
- tyre_identification.py: the tyre-model check and the online identification of the tyres' peak;
- slide_onset.py: the per-sample slide-onset test that hands v_t to the inertial estimate;
- mixer.py: the mixing laws S(15)-(17) (mix_checked) and the block VelocityMixer.
"""

from slipnav.systems.navigation.mixing.mixer import VelocityMixer, mix, mix_checked
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.weights import MixerC1, MixerC2C3

__all__ = ["MixerC1", "MixerC2C3", "MixingParameters", "VelocityMixer", "mix", "mix_checked"]
