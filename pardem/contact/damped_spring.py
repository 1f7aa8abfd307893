"""The damped linear spring's analytic properties (SPEC §3): contact time, restitution, and the
damping that gives a restitution ([contact] restitution).

Stage: set-up (the time step, the checks, the tests' expectations).
"""

from __future__ import annotations

import math


def damped_frequency(k_n: float, gamma_n: float, m_red: float) -> float:
    """omega (rad/s) of the damped normal spring: omega^2 = k_n/m_red - eta^2 with eta =
    gamma_n/(2 m_red). ValueError when overdamped (a contact never ends)."""
    eta = gamma_n / (2.0 * m_red)
    w2 = k_n / m_red - eta * eta
    if not w2 > 0:
        raise ValueError(f"overdamped: gamma_n/(2 m_red) = {eta:.4g} 1/s >= sqrt(k_n/m_red) = "
                         f"{math.sqrt(k_n / m_red):.4g} 1/s")
    return math.sqrt(w2)


def contact_time(k_n: float, gamma_n: float, m_red: float) -> float:
    """t_c = pi/omega (s) of the damped normal spring (SPEC §3)."""
    return math.pi / damped_frequency(k_n, gamma_n, m_red)


def restitution(k_n: float, gamma_n: float, m_red: float) -> float:
    """Normal restitution e_n = exp(-pi eta/omega) of the damped normal spring."""
    return math.exp(-math.pi * gamma_n / (2.0 * m_red) / damped_frequency(k_n, gamma_n, m_red))


def restitution_beta(e: float) -> float:
    """beta = 2L/sqrt(pi^2 + L^2), L = -ln e: the damped linear spring with gamma_n =
    beta sqrt(k_n m_red) rebounds with restitution e whatever m_red (e = exp(-pi eta/omega)
    solved for eta = gamma_n/(2 m_red), omega^2 = k_n/m_red - eta^2)."""
    return decrement_beta(-math.log(e))


def decrement_beta(big_l: float) -> float:
    """restitution_beta of the logarithmic decrement L = -ln e."""
    return 2.0 * big_l / math.sqrt(math.pi ** 2 + big_l ** 2)


def beta_decrement(beta: float) -> float:
    """L = -ln e of a beta (the inverse of decrement_beta): pi beta/sqrt(4 - beta^2)."""
    return math.pi * beta / math.sqrt(4.0 - beta * beta)


def contact_gamma(contact, k_n: float, m_red: float) -> float:
    """gamma_n (kg/s) of a contact of stiffness k_n (N/m) and reduced mass m_red (kg) under
    the [contact] table ``contact``: its gamma_n, or the one its restitution gives."""
    e = contact.restitution
    return contact.gamma_n if e is None else restitution_beta(e) * math.sqrt(k_n * m_red)
