"""Two disks in real LAMMPS: the trajectory, for the collision and reference-DEM tests."""

import numpy as np

from granavg.lammps_session import lammps_session

D, RHO_AREA = 0.00742, 1060 * 0.006


def lammps_trajectory(c, dt, start, frozen2, steps, wall_diameter=D):
    """x, v, omega of both disks after each step, and the masses/radii LAMMPS uses
    (a frozen second disk has diameter ``wall_diameter``)."""
    (x1, y1, vx1, vy1, w1), (x2, y2, vx2, vy2, w2) = start
    L = max(0.05, 1.5 * (D + wall_diameter))
    out = []
    with lammps_session(["-log", "none"]) as lmp:
        lmp.commands_string(f"""
            units si
            dimension 2
            boundary f f p
            atom_style sphere 1
            atom_modify map array sort 0 0
            comm_modify vel yes
            region box block -{L} {L} -{L} {L} -0.005 0.005
            create_box 4 box
            create_atoms 1 single {x1!r} {y1!r} 0
            create_atoms {4 if frozen2 else 1} single {x2!r} {y2!r} 0
            set type * diameter {D}
            set type 4 diameter {wall_diameter!r}
            set type * density/disc {RHO_AREA}
            set atom 1 vx {vx1!r} vy {vy1!r} omega 0 0 {w1!r}
            set atom 2 vx {vx2!r} vy {vy2!r} omega 0 0 {w2!r}
            group mobile type 1
            group walls type 4
            pair_style gran/hooke/history {c.kn!r} {c.kt!r} {c.gamma_n!r} {c.gamma_t!r} {c.mu!r} 1
            pair_coeff * *
            neighbor 0.002 bin
            fix integrate {"mobile" if frozen2 else "all"} nve/sphere disc
            fix frozen walls freeze
            fix flat all enforce2d
            timestep {dt!r}
            run 0""")
        mass = np.array(lmp.numpy.extract_atom("rmass")[:2])
        radius = np.array(lmp.numpy.extract_atom("radius")[:2])
        for _ in range(steps):
            lmp.command("run 1 pre no post no")
            out.append(np.concatenate([np.array(lmp.numpy.extract_atom(k)[:2, :2]).ravel()
                                       for k in ("x", "v")]
                                      + [np.array(lmp.numpy.extract_atom("omega")[:2, 2])]))
    return mass, radius, np.array(out)
