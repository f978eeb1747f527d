//! Interval arithmetic rounded outwards ([`Iv`]) and truncated Taylor polynomials ([`Jet`])
//! over any [`Num`] (plain floats for the table's nodes, intervals for its error bounds): the
//! map's formulas are written once over `Num` in the parent module.

/// A closed interval [lo, hi]; every operation encloses the exact result of its operands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iv {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

impl Iv {
    pub(super) fn new(lo: f64, hi: f64) -> Iv {
        Iv { lo, hi }
    }
    /// Largest magnitude.
    pub fn mag(self) -> f64 {
        self.lo.abs().max(self.hi.abs())
    }
}

/// The number type the map's formulas are written over: `f64` (node values) and [`Iv`]
/// (bounds). `None` where the formula leaves its domain (a logarithm or power of a range
/// that reaches zero, a division by one that contains it).
pub trait Num: Copy {
    /// A constant.
    fn c(x: f64) -> Self;
    /// Sum.
    fn add(self, o: Self) -> Self;
    /// Difference.
    fn sub(self, o: Self) -> Self;
    /// Product.
    fn mul(self, o: Self) -> Self;
    /// Quotient.
    fn div(self, o: Self) -> Option<Self>;
    /// e^x.
    fn exp(self) -> Self;
    /// ln x.
    fn ln(self) -> Option<Self>;
    /// x^e for x > 0.
    fn powf(self, e: f64) -> Option<Self>;
    /// `Some(true)` if surely > 0, `Some(false)` if surely < 0, else `None`.
    fn sign(self) -> Option<bool>;
    /// Surely greater than `x`.
    fn above(self, x: f64) -> bool;
}

impl Num for f64 {
    fn c(x: f64) -> f64 {
        x
    }
    fn add(self, o: f64) -> f64 {
        self + o
    }
    fn sub(self, o: f64) -> f64 {
        self - o
    }
    fn mul(self, o: f64) -> f64 {
        self * o
    }
    fn div(self, o: f64) -> Option<f64> {
        (o != 0.0).then(|| self / o)
    }
    fn exp(self) -> f64 {
        f64::exp(self)
    }
    fn ln(self) -> Option<f64> {
        (self > 0.0).then(|| f64::ln(self))
    }
    fn powf(self, e: f64) -> Option<f64> {
        (self > 0.0).then(|| f64::powf(self, e))
    }
    fn sign(self) -> Option<bool> {
        if self > 0.0 {
            Some(true)
        } else if self < 0.0 {
            Some(false)
        } else {
            None
        }
    }
    fn above(self, x: f64) -> bool {
        self > x
    }
}

/// Two steps down/up: enough for libm's exp, ln and pow (within one ulp).
pub(super) fn down2(x: f64) -> f64 {
    x.next_down().next_down()
}
pub(super) fn up2(x: f64) -> f64 {
    x.next_up().next_up()
}

impl Num for Iv {
    fn c(x: f64) -> Iv {
        Iv::new(x, x)
    }
    fn add(self, o: Iv) -> Iv {
        Iv::new((self.lo + o.lo).next_down(), (self.hi + o.hi).next_up())
    }
    fn sub(self, o: Iv) -> Iv {
        Iv::new((self.lo - o.hi).next_down(), (self.hi - o.lo).next_up())
    }
    fn mul(self, o: Iv) -> Iv {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Iv::new(lo.next_down(), hi.next_up())
    }
    fn div(self, o: Iv) -> Option<Iv> {
        if !(o.lo > 0.0 || o.hi < 0.0) {
            return None;
        }
        let r = Iv::new((1.0 / o.hi).next_down(), (1.0 / o.lo).next_up());
        Some(self.mul(r))
    }
    fn exp(self) -> Iv {
        Iv::new(down2(self.lo.exp()).max(0.0), up2(self.hi.exp()))
    }
    fn ln(self) -> Option<Iv> {
        (self.lo > 0.0).then(|| Iv::new(down2(self.lo.ln()), up2(self.hi.ln())))
    }
    fn powf(self, e: f64) -> Option<Iv> {
        if self.lo.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let (a, b) = (self.lo.powf(e), self.hi.powf(e));
        Some(Iv::new(down2(a.min(b)).max(0.0), up2(a.max(b))))
    }
    fn sign(self) -> Option<bool> {
        if self.lo > 0.0 {
            Some(true)
        } else if self.hi < 0.0 {
            Some(false)
        } else {
            None
        }
    }
    fn above(self, x: f64) -> bool {
        self.lo > x
    }
}

// ---------------------------------------------------------------------------------------
// Taylor polynomials: coefficient k is f^(k) / k!.

/// Degree of the Taylor polynomials: the fourth derivative at a point and the fifth over
/// a range bound the fourth over the range (a centred form, much tighter than enclosing
/// the fourth derivative over the range directly).
pub const ORDER: usize = 5;

/// A truncated Taylor series `sum_k c[k] (x - x0)^k`, k = 0..N-1 (by default N =
/// [`ORDER`] + 1), over a [`Num`].
///
/// Coefficient k of every operation is computed from the operands' coefficients 0..=k
/// alone, by the same operations whatever N is: a jet of fewer coefficients gives the
/// first coefficients of a longer one bit for bit. The map table's nodes need the value
/// and the slope only (N = 2), the midpoint of its centred form the fourth coefficient
/// (N = 5): both are computed with no more coefficients than they use.
#[derive(Debug, Clone, Copy)]
pub struct Jet<T, const N: usize = { ORDER + 1 }>(pub [T; N]);

impl<T: Num, const N: usize> Jet<T, N> {
    /// The variable itself at `x` (slope 1).
    pub fn var(x: T) -> Jet<T, N> {
        let mut j = [T::c(0.0); N];
        j[0] = x;
        j[1] = T::c(1.0);
        Jet(j)
    }
    pub(super) fn cst(x: f64) -> Jet<T, N> {
        let mut j = [T::c(0.0); N];
        j[0] = T::c(x);
        Jet(j)
    }
    pub(super) fn add(self, o: Jet<T, N>) -> Jet<T, N> {
        Jet(std::array::from_fn(|k| self.0[k].add(o.0[k])))
    }
    pub(super) fn sub(self, o: Jet<T, N>) -> Jet<T, N> {
        Jet(std::array::from_fn(|k| self.0[k].sub(o.0[k])))
    }
    pub(super) fn addc(self, x: f64) -> Jet<T, N> {
        let mut j = self;
        j.0[0] = j.0[0].add(T::c(x));
        j
    }
    pub(super) fn scale(self, x: f64) -> Jet<T, N> {
        Jet(self.0.map(|a| a.mul(T::c(x))))
    }
    pub(super) fn mul(self, o: Jet<T, N>) -> Jet<T, N> {
        Jet(std::array::from_fn(|k| {
            (1..=k).fold(self.0[0].mul(o.0[k]), |s, i| {
                s.add(self.0[i].mul(o.0[k - i]))
            })
        }))
    }
    pub(super) fn div(self, o: Jet<T, N>) -> Option<Jet<T, N>> {
        let mut q = [T::c(0.0); N];
        for k in 0..N {
            let mut s = self.0[k];
            for i in 1..=k {
                s = s.sub(o.0[i].mul(q[k - i]));
            }
            q[k] = s.div(o.0[0])?;
        }
        Some(Jet(q))
    }
    pub(super) fn exp(self) -> Jet<T, N> {
        let mut y = [T::c(0.0); N];
        y[0] = self.0[0].exp();
        for k in 1..N {
            let mut s = T::c(0.0);
            for j in 1..=k {
                // (j / k) a_j y_{k-j}
                s = s.add(T::c(j as f64).mul(self.0[j]).mul(y[k - j]));
            }
            y[k] = s.div(T::c(k as f64)).expect("k > 0");
        }
        Jet(y)
    }
    pub(super) fn ln(self) -> Option<Jet<T, N>> {
        let mut y = [T::c(0.0); N];
        y[0] = self.0[0].ln()?;
        for k in 1..N {
            let mut s = T::c(0.0);
            for j in 1..k {
                s = s.add(T::c(j as f64).mul(y[j]).mul(self.0[k - j]));
            }
            let s = s.div(T::c(k as f64)).expect("k > 0");
            y[k] = self.0[k].sub(s).div(self.0[0])?;
        }
        Some(Jet(y))
    }
    /// x^e of a positive x: `k a_0 y_k = sum_{j=1..k} ((e + 1) j - k) a_j y_{k-j}`.
    pub(super) fn powf(self, e: f64) -> Option<Jet<T, N>> {
        let mut y = [T::c(0.0); N];
        y[0] = self.0[0].powf(e)?;
        let e1 = T::c(e).add(T::c(1.0));
        for k in 1..N {
            let mut s = T::c(0.0);
            for j in 1..=k {
                let c = e1.mul(T::c(j as f64)).sub(T::c(k as f64));
                s = s.add(c.mul(self.0[j]).mul(y[k - j]));
            }
            y[k] = s.div(T::c(k as f64).mul(self.0[0]))?;
        }
        Some(Jet(y))
    }
    pub(super) fn abs(self) -> Option<Jet<T, N>> {
        match self.0[0].sign()? {
            true => Some(self),
            false => Some(Jet(self.0.map(|a| T::c(0.0).sub(a)))),
        }
    }
}
