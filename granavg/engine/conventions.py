"""The definitions and sign conventions of the micropolar and energy quantities, as the
sidecar's ``micropolar`` entry states them (docs/profiles.md)."""

#: The micropolar and energy quantities the sidecar's ``micropolar`` entry explains.
MICROPOLAR = ("mu", "dmu", "spin_density", "couple_density", "boundary_couple", "lever",
              "contact_power", "wall_power", "lever_power", "body_power", "ekin", "erot",
              "temperature", "temperature_rot")
#: Their definitions and sign conventions, for the sidecar (docs/profiles.md).
MICROPOLAR_CONVENTIONS = {
    "couple": "m, the contact couple on a particle beyond the moment of the forces "
              "(rolling and twisting resistance; contact columns mz, or mx my mz; the "
              "other particle gets -m); counter-clockwise positive about z in 2D",
    "mu": "couple stress (1/V) sum_p w_p sum_c l_i m_j: first index the branch vector's "
          "(the face's normal), second the couple's; 2D: mu_<i> = l_i m_z; l to the "
          "contact point as the stress's",
    "dmu": "flux of the spins' angular momentum (1/V) sum w v_i I omega_j, I = k m a^2 "
           "(k = 1/2 disks, 2/5 spheres)",
    "balance": "div(mu - dmu) + tau + lever + couples passed at walls = d(spin_density)/dt, "
               "tau_z = sigma_yx - sigma_xy (sigma_ij = f_i l_j), divergence on mu's first "
               "index (granavg.analysis.spin_balance)",
    "lever": "(1/V) sum w sum_c (delta/2) n x f: what a law whose torque arm ends at the "
             "surface (pair gran/*) adds to one ending at the contact point (pair granular)",
    "powers": "power the contacts deliver to the particles, f . (v + omega x l) + m . "
              "omega, per volume (W/m^3 in SI): in a steady state's time average minus "
              "the dissipation rate (the elastic energy's rate averages out); body_power "
              "b . v",
}
