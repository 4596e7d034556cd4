"""Random linear-quadratic problems and their dense references, shared by the chapter 6 tests: a dense KKT
solve of the finite-horizon problem and the Hessian of its controls (the independent route the Riccati
recursion is checked against), and random hypotheses with J1 curved more than J0."""

import numpy as np

from mutual.motion.legible import LinearDynamics, QuadraticCost


def random_problem(seed, n=3, m=2, N=12, convex_state=True, q_scale=0.02):
    """A time-varying LQ problem with cross terms and affine dynamics."""
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.1 * rng.normal(size=(N, n, n))
    B = rng.normal(size=(N, n, m))
    c = 0.1 * rng.normal(size=(N, n))
    L = rng.normal(size=(N, n, n))
    Q = L @ L.transpose(0, 2, 1) / n if convex_state else q_scale * (L + L.transpose(0, 2, 1))
    Lr = rng.normal(size=(N, m, m))
    R = Lr @ Lr.transpose(0, 2, 1) / m + np.eye(m)
    M = 0.1 * rng.normal(size=(N, n, m)) if not convex_state else np.zeros((N, n, m))
    LN = rng.normal(size=(n, n))
    return dict(A=A, B=B, c=c, Q=Q, R=R, M=M, q=rng.normal(size=(N, n)), r=rng.normal(size=(N, m)),
                QN=LN @ LN.T, qN=rng.normal(size=n), x0=rng.normal(size=n), N=N)


def kkt_solve(p):
    """Minimise the LQ cost by one dense KKT system in z = (x_0..x_N, u_0..u_{N-1})."""
    A, B, N = p["A"], p["B"], p["N"]
    n, m = B.shape[1:]
    nx, nz = (N + 1) * n, (N + 1) * n + N * m
    H = np.zeros((nz, nz))
    g = np.zeros(nz)
    xi = lambda k: slice(k * n, (k + 1) * n)  # noqa: E731
    ui = lambda k: slice(nx + k * m, nx + (k + 1) * m)  # noqa: E731
    for k in range(N):
        H[xi(k), xi(k)] += p["Q"][k]
        H[ui(k), ui(k)] += p["R"][k]
        H[xi(k), ui(k)] += p["M"][k]
        H[ui(k), xi(k)] += p["M"][k].T
        g[xi(k)] += p["q"][k]
        g[ui(k)] += p["r"][k]
    H[xi(N), xi(N)] += p["QN"]
    g[xi(N)] += p["qN"]
    E = np.zeros(((N + 1) * n, nz))
    e = np.zeros((N + 1) * n)
    E[:n, :n] = np.eye(n)
    e[:n] = p["x0"]
    for k in range(N):
        rows = slice((k + 1) * n, (k + 2) * n)
        E[rows, xi(k + 1)] = np.eye(n)
        E[rows, xi(k)] = -A[k]
        E[rows, ui(k)] = -B[k]
        e[rows] = p["c"][k]
    kkt = np.block([[H, E.T], [E, np.zeros((len(e), len(e)))]])
    z = np.linalg.solve(kkt, np.concatenate([-g, e]))[:nz]
    return z[:nx].reshape(N + 1, n), z[nx:].reshape(N, m)


def control_hessian(p):
    """Hessian of the total cost in the stacked controls (the dynamics eliminated), densely."""
    N, (n, m) = p["N"], p["B"].shape[1:]
    G = np.zeros((N + 1, n, N * m))                    # d x_k / d u
    for k in range(N):
        G[k + 1] = p["A"][k] @ G[k]
        G[k + 1, :, k * m:(k + 1) * m] += p["B"][k]
    H = np.einsum("kia,kij,kjb->ab", G[:N], p["Q"], G[:N]) + G[N].T @ p["QN"] @ G[N]
    for k in range(N):
        U = np.zeros((m, N * m))
        U[:, k * m:(k + 1) * m] = np.eye(m)
        H += U.T @ p["R"][k] @ U + G[k].T @ p["M"][k] @ U + U.T @ p["M"][k].T @ G[k]
    return H


def rollout(dyn, x0, us):
    xs = [x0]
    for u in us:
        xs.append(dyn.A @ xs[-1] + dyn.B @ u)
    return np.array(xs)


def random_cost(rng, n, m, N, effort=1.0):
    """A random time-varying convex quadratic cost."""
    L = rng.normal(size=(N, n, n))
    Lr = rng.normal(size=(N, m, m))
    LN = rng.normal(size=(n, n))
    return QuadraticCost(Q=L @ L.transpose(0, 2, 1) / n, q=rng.normal(size=(N, n)),
                         R=Lr @ Lr.transpose(0, 2, 1) / m + effort * np.eye(m), r=rng.normal(size=(N, m)),
                         QN=LN @ LN.T, qN=rng.normal(size=n), const=rng.normal())


def random_hypotheses(seed, n=2, m=2, N=10):
    """Random LQ hypotheses with J1 curved more than J0, so that Lambda has a minimiser."""
    rng = np.random.default_rng(seed)
    dyn = LinearDynamics(np.eye(n) + 0.2 * rng.normal(size=(n, n)), rng.normal(size=(n, m)))
    J0 = random_cost(rng, n, m, N)
    J1 = J0 + random_cost(rng, n, m, N, effort=0.5)     # H1 - H0 positive definite
    return dyn, J0, J1, rng.normal(size=n), N
