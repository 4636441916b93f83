//! The seed's 2-D examples as data: the gallery meshes them, docs/cli.md lists them as
//! commands, and the quality tests check them (one definition for all three).

/// One example: the `trussmesh mesh` flags that mesh it.
#[derive(Debug, Clone, Copy)]
pub struct Example {
    /// File stem and table row name.
    pub name: &'static str,
    /// What it is.
    pub title: &'static str,
    /// d(x, y) < 0 inside.
    pub domain: &'static str,
    /// Relative size h(x, y); `None` is uniform.
    pub size: Option<&'static str>,
    /// Initial edge length (constant expression).
    pub h0: &'static str,
    /// X0,Y0,X1,Y1.
    pub bbox: &'static str,
    /// Fixed points "x,y;x,y".
    pub fix: Option<&'static str>,
    /// The domain is a level set, not a signed distance (`--implicit`).
    pub implicit: bool,
    /// Internal boundaries d_I(x, y) = 0 (`--internal`).
    pub internal: Option<&'static str>,
    /// Anisotropic metric "A;B;C" (`--metric`).
    pub metric: Option<&'static str>,
}

/// Every 2-D example of the seed (section 2.5, figure 2-4; the ellipse of figure 3-3; the
/// internal boundaries of figure 3-5 and the anisotropic circle of figure 3-6).
/// Example 1 from a grid is left out: the command line has no grid input.
pub const EXAMPLES: &[Example] = &[
    Example {
        name: "ex1a",
        title: "unit circle, h0 = 0.4",
        domain: "sqrt(x^2+y^2)-1",
        size: None,
        h0: "0.4",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex1b",
        title: "unit circle, h0 = 0.2",
        domain: "sqrt(x^2+y^2)-1",
        size: None,
        h0: "0.2",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex1c",
        title: "unit circle, h0 = 0.1",
        domain: "sqrt(x^2+y^2)-1",
        size: None,
        h0: "0.1",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex2",
        title: "circle with a hole",
        domain: "-0.3+abs(0.7-sqrt(x^2+y^2))",
        size: None,
        h0: "0.1",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex3a",
        title: "square with a hole",
        domain: "ddiff(drectangle(x,y,-1,1,-1,1), dcircle(x,y,0,0,0.4))",
        size: None,
        h0: "0.15",
        bbox: "-1,-1,1,1",
        fix: Some("-1,-1; -1,1; 1,-1; 1,1"),
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex3b",
        title: "square with a hole, refined near the hole",
        domain: "ddiff(drectangle(x,y,-1,1,-1,1), dcircle(x,y,0,0,0.4))",
        size: Some("min(4*sqrt(x^2+y^2)-1, 2)"),
        h0: "0.05",
        bbox: "-1,-1,1,1",
        fix: Some("-1,-1; -1,1; 1,-1; 1,1"),
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex4",
        title: "hexagon minus a smaller rotated hexagon",
        domain: "ddiff(dpoly(x,y, 1,0, 0.5,sqrt(3)/2, -0.5,sqrt(3)/2, -1,0, -0.5,-sqrt(3)/2, 0.5,-sqrt(3)/2), dpoly(x,y, sqrt(3)/4,0.25, 0,0.5, -sqrt(3)/4,0.25, -sqrt(3)/4,-0.25, 0,-0.5, sqrt(3)/4,-0.25))",
        size: None,
        h0: "0.1",
        bbox: "-1,-1,1,1",
        fix: Some(concat!(
            "1,0; 0.5,sqrt(3)/2; -0.5,sqrt(3)/2; -1,0; -0.5,-sqrt(3)/2; 0.5,-sqrt(3)/2; ",
            "sqrt(3)/4,0.25; 0,0.5; -sqrt(3)/4,0.25; -sqrt(3)/4,-0.25; 0,-0.5; sqrt(3)/4,-0.25"
        )),
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex5",
        title: "geometric adaptivity",
        domain: "max(sqrt(x^2+y^2)-1, -(sqrt((x+0.4)^2+y^2)-0.55), -y)",
        size: Some("min(0.15-0.2*(sqrt(x^2+y^2)-1), 0.06+0.2*(sqrt((x+0.4)^2+y^2)-0.55), ((sqrt((x+0.4)^2+y^2)-0.55)-(sqrt(x^2+y^2)-1))/3)"),
        h0: "0.05/3",
        bbox: "-1,0,1,1",
        fix: Some("-1,0; -0.95,0; 0.15,0; 1,0"),
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex6",
        title: "between level sets 0.5 and 1 of (x^4+y^4)^(1/4)",
        domain: "max((x^4+y^4)^(1/4)-1, 0.5-(x^4+y^4)^(1/4))",
        size: None,
        h0: "0.1",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: true,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex7",
        title: "y <= cos(x) and y >= 5 (2x/(5 pi))^4 - 5",
        domain: "max(y-cos(x), 5*(2*x/(5*pi))^4-5-y)",
        size: None,
        h0: "0.3",
        bbox: "-5*pi/2,-5,5*pi/2,1",
        fix: Some("-5*pi/2,0; 5*pi/2,0"),
        implicit: true,
        internal: None,
        metric: None,
    },
    Example {
        name: "ex8",
        title: "rectangle and circle with a circular hole, graded from two corners and the hole",
        domain: "ddiff(dunion(drectangle(x,y,-1,0.5,-0.5,0.5), dcircle(x,y,0.5,0,0.7)), dcircle(x,y,-0.4,0,0.2))",
        size: Some("min(1+5*dcircle(x,y,-1,-0.5,0), 1+5*dcircle(x,y,-1,0.5,0), 1+5*dcircle(x,y,-0.4,0,0.2), 6)"),
        h0: "0.02",
        bbox: "-1,-0.7,1.2,0.7",
        fix: Some("-1,-0.5; -1,0.5"),
        implicit: false,
        internal: None,
        metric: None,
    },
    Example {
        name: "ellipse",
        title: "ellipse x^2/4 + y^2 < 1 (implicit, figure 3-3)",
        domain: "x^2/4+y^2-1",
        size: None,
        h0: "0.2",
        bbox: "-2,-1,2,1",
        fix: None,
        implicit: true,
        internal: None,
        metric: None,
    },
    Example {
        name: "fig3-5",
        title: "square with a circle and a polygon as internal boundaries",
        domain: "drectangle(x,y,-1,1,-1,1)",
        size: None,
        h0: "0.05",
        bbox: "-1,-1,1,1",
        fix: Some("-1,-1; 1,-1; 1,1; -1,1; 0.15,-0.55; 0.75,-0.65; 0.65,0.05; 0.35,0.35; 0.1,-0.05"),
        implicit: false,
        internal: Some(
            "min(dcircle(x,y,-0.45,0.35,0.35), dpoly(x,y, 0.15,-0.55, 0.75,-0.65, 0.65,0.05, 0.35,0.35, 0.1,-0.05))",
        ),
        metric: None,
    },
    Example {
        name: "fig3-6",
        title: "anisotropic unit circle: radial size min(0.01 + 0.3 (1 - r), 0.2), tangential 0.2",
        domain: "sqrt(x^2+y^2)-1",
        size: None,
        h0: "0.01",
        bbox: "-1,-1,1,1",
        fix: None,
        implicit: false,
        internal: None,
        metric: Some(
            "25+x^2*(1/min(0.01+0.3*(1-sqrt(x^2+y^2)),0.2)^2-25)/(x^2+y^2+1e-300); x*y*(1/min(0.01+0.3*(1-sqrt(x^2+y^2)),0.2)^2-25)/(x^2+y^2+1e-300); 25+y^2*(1/min(0.01+0.3*(1-sqrt(x^2+y^2)),0.2)^2-25)/(x^2+y^2+1e-300)",
        ),
    },
];

impl Example {
    /// The arguments after `trussmesh`, with the given outputs.
    pub fn args(&self, outputs: &[String]) -> Vec<String> {
        let mut a: Vec<String> = vec!["mesh".into(), "--dim".into(), "2".into()];
        let mut push = |flag: &str, v: &str| {
            a.push(flag.into());
            a.push(v.into());
        };
        push("--domain", self.domain);
        if let Some(s) = self.size {
            push("--size", s);
        }
        push("--h0", self.h0);
        push("--bbox", self.bbox);
        if let Some(f) = self.fix {
            push("--fix", f);
        }
        if let Some(d) = self.internal {
            push("--internal", d);
        }
        if let Some(m) = self.metric {
            push("--metric", m);
        }
        if self.implicit {
            a.push("--implicit".into());
        }
        for o in outputs {
            a.push("-o".into());
            a.push(o.clone());
        }
        a
    }

    /// The shell command docs/cli.md shows: writes out/NAME.vtu and out/NAME.svg.
    pub fn command_line(&self) -> String {
        let outs = [format!("out/{}.vtu", self.name), format!("out/{}.svg", self.name)];
        let mut s = String::from("trussmesh");
        for a in self.args(&outs) {
            s.push(' ');
            s.push_str(&shell_quote(&a));
        }
        s
    }
}

/// Single-quotes a word when the shell would otherwise change it.
fn shell_quote(w: &str) -> String {
    let plain = !w.is_empty() && w.chars().all(|c| c.is_ascii_alphanumeric() || "-_./,=".contains(c));
    if plain {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', r"'\''"))
    }
}

/// A constant expression (such as `0.05/3` or `-5*pi/2`) evaluated.
fn constant(src: &str) -> Result<f64, crate::Error> {
    let e = crate::expr::Expr::parse(src).map_err(|e| crate::Error::Invalid(format!("'{src}': {e}")))?;
    let v = e.eval(0.0, 0.0, 0.0);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(crate::Error::Invalid(format!("'{src}' is not a finite number")))
    }
}

impl Example {
    /// The geometry and options of this example, as the library takes them.
    pub fn build(&self) -> Result<(crate::expr::ExprImplicit2, crate::mesher::Options2), crate::Error> {
        use crate::expr::{Expr, ExprImplicit2};
        let parse = |s: &str| Expr::parse(s).map_err(|e| crate::Error::Invalid(format!("'{s}': {e}")));
        let mut domain = ExprImplicit2::new(parse(self.domain)?);
        domain.distance = !self.implicit;
        let b: Vec<f64> = self.bbox.split(',').map(constant).collect::<Result<_, _>>()?;
        if b.len() != 4 {
            return Err(crate::Error::Invalid(format!("bbox '{}' needs four values", self.bbox)));
        }
        let mut opts = crate::mesher::Options2::uniform(constant(self.h0)?, [b[0], b[1]], [b[2], b[3]]);
        if let Some(s) = self.size {
            let h = parse(s)?;
            opts = opts.with_size(move |p| h.eval(p.x, p.y, 0.0));
        }
        if let Some(f) = self.fix {
            let mut pts = Vec::new();
            for pair in f.split(';').filter(|s| !s.trim().is_empty()) {
                let xy: Vec<f64> = pair.split(',').map(|s| constant(s.trim())).collect::<Result<_, _>>()?;
                if xy.len() != 2 {
                    return Err(crate::Error::Invalid(format!("fixed point '{pair}' needs two values")));
                }
                pts.push([xy[0], xy[1]]);
            }
            opts = opts.with_fixed(pts);
        }
        if let Some(d) = self.internal {
            let mut di = ExprImplicit2::new(parse(d)?);
            di.distance = !self.implicit;
            opts = opts.with_internal(di);
        }
        if let Some(m) = self.metric {
            let parts: Vec<Expr> = m.split(';').map(parse).collect::<Result<_, _>>()?;
            if parts.len() != 3 {
                return Err(crate::Error::Invalid(format!("metric '{m}' needs three expressions")));
            }
            opts = opts.with_metric(move |p| {
                let e = |k: usize| parts[k].eval(p.x, p.y, 0.0);
                crate::mesher::Metric2::new(e(0), e(1), e(2))
            });
        }
        Ok((domain, opts))
    }

    /// The exact area of the domain, where it is known.
    pub fn exact_area(&self) -> Option<f64> {
        use std::f64::consts::PI;
        match self.name {
            "ex1a" | "ex1b" | "ex1c" => Some(PI),
            "ex2" => Some(PI * (1.0 - 0.16)),
            "ex3a" | "ex3b" => Some(4.0 - PI * 0.16),
            "fig3-5" => Some(4.0),
            "fig3-6" => Some(PI),
            "ex4" => Some(3.0 * 3f64.sqrt() / 2.0 * (1.0 - 0.25)),
            "ellipse" => Some(PI * 2.0),
            _ => None,
        }
    }
}
