//! The expression language: grammar, every function against std, analytic gradients against
//! finite differences, dpoly against known distances, and error columns.

use std::f64::consts::{E, PI};

use glam::{DVec2, DVec3};
use trussmesh::expr::{fuzz_parse, Expr, ExprError, ExprImplicit2, ExprImplicit3};
use trussmesh::geometry::{Implicit2, Implicit3};

fn ev(src: &str, x: f64, y: f64, z: f64) -> f64 {
    Expr::parse(src).unwrap_or_else(|e| panic!("{src}: {e}")).eval(x, y, z)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    a == b || (a - b).abs() <= tol * (1.0 + b.abs()) || (a.is_nan() && b.is_nan())
}

/// splitmix64, so the random points are the same on every run.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

#[test]
fn corpus_replays() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/expr");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            fuzz_parse(&std::fs::read(&path).unwrap());
            n += 1;
        }
    }
    assert!(n >= 10, "corpus has only {n} files");
}

#[test]
fn precedence_and_associativity() {
    let cases: &[(&str, f64)] = &[
        ("1+2*3", 7.0),
        ("(1+2)*3", 9.0),
        ("1-2-3", -4.0),
        ("1-(2-3)", 2.0),
        ("12/3/2", 2.0),
        ("2*3/4", 1.5),
        ("2^3^2", 512.0),
        ("(2^3)^2", 64.0),
        ("-2^2", -4.0),
        ("(-2)^2", 4.0),
        ("2^-2", 0.25),
        ("-2^-2", -0.25),
        ("2*-3", -6.0),
        ("--2", 2.0),
        ("+-+2", -2.0),
        ("-3*2^2", -12.0),
        ("1 - -1", 2.0),
        ("2^3*2", 16.0),
        ("2*3^2", 18.0),
        ("1.5 + .5 + 1e-3 + 2.5E+2 + 3e2 + 4.", 1.5 + 0.5 + 1e-3 + 250.0 + 300.0 + 4.0),
        ("pi", PI),
        ("e", E),
        ("2*pi*e", 2.0 * PI * E),
    ];
    for &(s, want) in cases {
        assert_eq!(ev(s, 0.0, 0.0, 0.0), want, "{s}");
    }
    // With variables, so nothing is folded away.
    let (x, y, z) = (1.7, -0.3, 2.2);
    assert_eq!(ev("-x^2", x, y, z), -(x * x));
    assert_eq!(ev("x-y-z", x, y, z), x - y - z);
    assert_eq!(ev("x/y/z", x, y, z), x / y / z);
    assert_eq!(ev("x^y^z", x, -y, z), x.powf((-y).powf(z)));
    assert_eq!(ev("x+y*z", x, y, z), x + y * z);
    assert_eq!(ev("-x*y", x, y, z), -x * y);
    assert_eq!(ev("2-x", x, y, z), 2.0 - x);
    assert_eq!(ev("2/x", x, y, z), 2.0 / x);
    assert_eq!(ev("2^x", x, y, z), 2f64.powf(x));
    assert_eq!(ev("x^0.5", x, y, z), x.powf(0.5));
}

#[test]
fn functions_match_std() {
    type F1 = fn(f64) -> f64;
    let unary: &[(&str, F1)] = &[
        ("sqrt", f64::sqrt),
        ("abs", f64::abs),
        ("sin", f64::sin),
        ("cos", f64::cos),
        ("tan", f64::tan),
        ("exp", f64::exp),
        ("ln", f64::ln),
        ("log", f64::ln),
        ("log10", f64::log10),
        ("floor", f64::floor),
        ("ceil", f64::ceil),
    ];
    let xs = [-3.7, -1.0, -0.25, 0.0, 0.3, 1.0, 2.5, 10.0, 1e3];
    for &(name, f) in unary {
        let e = Expr::parse(&format!("{name}(x)")).unwrap();
        for x in xs {
            assert!(close(e.eval(x, 0.0, 0.0), f(x), 1e-15), "{name}({x})");
            // The folded form agrees too.
            let c = ev(&format!("{name}({x:e})"), 0.0, 0.0, 0.0);
            assert!(close(c, f(x), 1e-15), "folded {name}({x})");
        }
    }
    let mut rng = Rng(7);
    for _ in 0..50 {
        let (x, y, z) = (rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
        let (a, b) = (rng.range(0.1, 3.0), rng.range(-2.0, 2.0));
        let chk = |s: &str, want: f64| {
            let got = ev(s, x, y, z);
            assert!(close(got, want, 1e-13), "{s} at ({x},{y},{z}): {got} vs {want}");
        };
        chk("pow(x, y)", x.powf(y));
        chk(&format!("pow({a}, y)"), a.powf(y));
        chk("x^3", x.powi(3));
        chk("atan2(y, x)", y.atan2(x));
        chk("min(x)", x);
        chk("min(x, y)", x.min(y));
        chk("min(x, y, z, 0.5)", x.min(y).min(z).min(0.5));
        chk("max(x, y, z, -0.5)", x.max(y).max(z).max(-0.5));
        chk("dunion(x, y, z)", x.min(y).min(z));
        chk("dintersect(x, y, z)", x.max(y).max(z));
        chk("ddiff(x, y)", x.max(-y));
        chk(&format!("dcircle(x, y, {a}, {b}, 0.7)"), ((x - a).powi(2) + (y - b).powi(2)).sqrt() - 0.7);
        chk(
            &format!("dsphere(x, y, z, {a}, {b}, 0.25, 1.5)"),
            ((x - a).powi(2) + (y - b).powi(2) + (z - 0.25).powi(2)).sqrt() - 1.5,
        );
        let (x1, x2, y1, y2, z1, z2) = (-1.0, a, b - 1.0, b + 0.5, -0.5, 2.0);
        chk(&format!("drectangle(x, y, {x1}, {x2}, {y1}, {y2})"), -(-y1 + y).min(y2 - y).min(-x1 + x).min(x2 - x));
        chk(
            &format!("dbox(x, y, z, {x1}, {x2}, {y1}, {y2}, {z1}, {z2})"),
            -(-z1 + z).min(z2 - z).min(-y1 + y).min(y2 - y).min(-x1 + x).min(x2 - x),
        );
    }
}

fn square() -> &'static str {
    "dpoly(x, y, 0,0, 1,0, 1,1, 0,1)"
}

fn hexagon() -> String {
    let v: Vec<String> = (0..6)
        .map(|k| {
            let t = k as f64 * PI / 3.0;
            format!("{:e},{:e}", t.cos(), t.sin())
        })
        .collect();
    format!("dpoly(x, y, {})", v.join(", "))
}

#[test]
fn dpoly_known_distances() {
    let sq = Expr::parse(square()).unwrap();
    let cases = [
        ((0.5, 0.5), -0.5),
        ((0.25, 0.5), -0.25),
        ((0.9, 0.2), -0.1),
        ((2.0, 0.5), 1.0),
        ((0.5, -0.3), 0.3),
        ((2.0, 2.0), 2f64.sqrt()),
        ((-1.0, -1.0), 2f64.sqrt()),
        ((0.5, 0.0), 0.0),
        ((1.0, 1.0), 0.0),
    ];
    for ((x, y), want) in cases {
        let got = sq.eval(x, y, 0.0);
        assert!(close(got, want, 1e-14), "square at ({x},{y}): {got} vs {want}");
    }
    // Clockwise order gives the same distances.
    let cw = Expr::parse("dpoly(x, y, 0,0, 0,1, 1,1, 1,0)").unwrap();
    for ((x, y), want) in cases {
        assert!(close(cw.eval(x, y, 0.0), want, 1e-14));
    }
    let hx = Expr::parse(&hexagon()).unwrap();
    let apothem = (PI / 6.0).cos();
    let cases = [
        ((0.0, 0.0), -apothem),
        ((2.0, 0.0), 1.0),
        ((0.0, 2.0), 2.0 - apothem),
        ((0.0, -0.5), 0.5 - apothem),
        ((0.0, apothem), 0.0),
        ((-3.0, 0.0), 2.0),
    ];
    for ((x, y), want) in cases {
        let got = hx.eval(x, y, 0.0);
        assert!(close(got, want, 1e-12), "hexagon at ({x},{y}): {got} vs {want}");
    }
    // Inside a regular hexagon the distance is the apothem minus the projection on the
    // nearest edge normal.
    let mut rng = Rng(11);
    for _ in 0..200 {
        let (x, y) = (rng.range(-0.8, 0.8), rng.range(-0.8, 0.8));
        let proj = (0..6)
            .map(|k| {
                let t = (k as f64 + 0.5) * PI / 3.0;
                x * t.cos() + y * t.sin()
            })
            .fold(f64::NEG_INFINITY, f64::max);
        if proj < apothem {
            assert!(close(hx.eval(x, y, 0.0), proj - apothem, 1e-12));
        }
    }
}

/// Central differences, skipping components where the one-sided slopes disagree (a kink).
fn check_gradient(src: &str, seed: u64, lo: f64, hi: f64) {
    let e = Expr::parse(src).unwrap();
    let mut rng = Rng(seed);
    let mut checked = 0;
    for _ in 0..200 {
        let p = [rng.range(lo, hi), rng.range(lo, hi), rng.range(lo, hi)];
        let (v, g) = e.eval_grad(p[0], p[1], p[2]);
        assert_eq!(v.to_bits(), e.eval(p[0], p[1], p[2]).to_bits(), "{src}");
        for i in 0..3 {
            let h = 1e-6;
            let f = |d: f64| {
                let mut q = p;
                q[i] += d;
                e.eval(q[0], q[1], q[2])
            };
            let (fp, f0, fm) = (f(h), f(0.0), f(-h));
            let central = (fp - fm) / (2.0 * h);
            let (fwd, bwd) = ((fp - f0) / h, (f0 - fm) / h);
            if !central.is_finite() || (fwd - bwd).abs() > 1e-3 * (1.0 + central.abs()) {
                continue;
            }
            assert!(
                (g[i] - central).abs() <= 1e-5 * (1.0 + central.abs()),
                "{src}: d/d{} at {p:?} = {} but finite difference {central}",
                ["x", "y", "z"][i],
                g[i]
            );
            checked += 1;
        }
    }
    assert!(checked > 300, "{src}: only {checked} components checked");
}

#[test]
fn gradients_match_finite_differences() {
    let exprs = [
        "max(sqrt(x^2+y^2)-1, -(sqrt((x+0.4)^2+y^2)-0.55), -y)",
        "x*y*z + x/(2+y^2) - 3*z^3 + 2^x + x^-2 + (1+x^2)^0.75",
        "sin(x)*cos(y) + tan(z/3) + exp(x/2) + ln(2+y) + log10(3+z) + log(4+x)",
        "sqrt(1+x^2+y^2) + abs(x-y) + abs(z)",
        "min(x, y, z) + max(x^2, y, 0.5) + min(x*y, 1)",
        "pow(2+x^2, y) + pow(y, 3) + atan2(y, x) + atan2(z, 1+x^2)",
        "floor(x)*y + ceil(z) + x",
        "asin(x/3) + acos(y/3) + atan(x*z) + sinh(x/2) + cosh(y/2) + tanh(z) + sign(x-y)*z",
        "cbrt(x^3 - 2*y + 0.5) + hypot(x - z, y^2 + 1) + hypot(2, x)",
        "dcircle(x, y, 0.2, -0.1, 1) + dsphere(x, y, z, 0, 1, 2, 0.5)",
        "drectangle(x, y, -1, 1, -0.5, 0.5) + dbox(x, y, z, -1, 1, -1, 2, 0, 1)",
        "dunion(dcircle(x,y,0,0,1), dcircle(x,y,1,0,0.5)) + ddiff(x, y) + dintersect(x, y, z)",
        "dpoly(x, y, 0,0, 1,0, 1,1, 0,1)",
        "dpoly(x, y, 0,0, 2,0, 0.5,0.5, 0,2)",
        "dpoly(x, y, 0,0, 1+z,0, 1,1+x*z, 0,1) + dpoly(y, x, z,0, 1,0, 1,1, 0,1)",
        "-(x^2) - x^3 / (1 + y^2) + 2 - x + 3*y - z/4 + 1/(5+x)",
    ];
    for (k, s) in exprs.iter().enumerate() {
        check_gradient(s, 100 + k as u64, -2.0, 2.0);
    }
    let hx = hexagon();
    check_gradient(&hx, 99, -1.5, 1.5);
}

#[test]
fn gradient_at_special_points() {
    // The centre of a circle: zero rather than NaN.
    let e = Expr::parse("sqrt(x^2+y^2) - 1").unwrap();
    assert_eq!(e.eval_grad(0.0, 0.0, 0.0), (-1.0, [0.0, 0.0, 0.0]));
    // A constant exponent on a negative base stays finite.
    let e = Expr::parse("x^3 + x^2").unwrap();
    assert_eq!(e.eval_grad(-2.0, 0.0, 0.0), (-4.0, [8.0, 0.0, 0.0]));
    // Through abs, min and max the active branch decides.
    let e = Expr::parse("max(abs(x), min(y, 2*z))").unwrap();
    assert_eq!(e.eval_grad(-3.0, 1.0, 1.0).1, [-1.0, 0.0, 0.0]);
    assert_eq!(e.eval_grad(0.5, 1.0, 0.4).1, [0.0, 0.0, 2.0]);
    // Signed distance gradients have unit length.
    let e = Expr::parse(square()).unwrap();
    let (_, g) = e.eval_grad(0.3, 0.4, 0.0);
    assert_eq!(g, [-1.0, 0.0, 0.0]);
    let (_, g) = e.eval_grad(2.0, 2.0, 0.0);
    assert!((g[0] - 0.5f64.sqrt()).abs() < 1e-15 && (g[1] - 0.5f64.sqrt()).abs() < 1e-15);
}

#[test]
fn metadata_and_wrappers() {
    let e = Expr::parse("dcircle(x, y, 0, 0, 1)").unwrap();
    assert!(!e.uses_z());
    assert_eq!(e.source(), "dcircle(x, y, 0, 0, 1)");
    assert!(Expr::parse("x + 0*z").unwrap().uses_z());
    let g2 = ExprImplicit2::new(e.clone());
    assert!(!g2.is_distance());
    assert_eq!(g2.value(DVec2::new(2.0, 0.0)), 1.0);
    assert_eq!(g2.gradient(DVec2::new(0.0, 3.0)), DVec2::new(0.0, 1.0));
    let g2 = ExprImplicit2 { distance: true, ..g2 };
    assert!(g2.is_distance());
    let g3 = ExprImplicit3::new(Expr::parse("dsphere(x, y, z, 0, 0, 0, 1)").unwrap());
    assert_eq!(g3.value(DVec3::new(0.0, 0.0, 3.0)), 2.0);
    assert_eq!(g3.gradient(DVec3::new(0.0, 0.0, 3.0)), DVec3::Z);
    fn assert_traits<T: Clone + Send + Sync + std::fmt::Debug>() {}
    assert_traits::<Expr>();
}

fn err(src: &str) -> ExprError {
    match Expr::parse(src) {
        Ok(_) => panic!("{src:?} parsed"),
        Err(e) => e,
    }
}

#[test]
fn error_columns_and_messages() {
    let cases: &[(&str, usize, &str)] = &[
        ("", 1, "empty expression"),
        ("(x+1", 5, "expected ')' to close the '(' at column 1"),
        ("sqrt((x-1)", 11, "arguments of 'sqrt'"),
        ("x+1)", 4, "unexpected ')'"),
        ("sqr(x)", 1, "unknown function 'sqr'"),
        ("1 + sqr(x)", 5, "unknown function 'sqr'"),
        ("x + w", 5, "unknown variable 'w'"),
        ("x(2)", 1, "unknown function 'x'"),
        ("sqrt", 1, "function 'sqrt' needs its arguments"),
        ("dcircle(x,y,1)", 1, "dcircle expects 5 arguments, got 3"),
        ("2*sqrt(x, y)", 3, "sqrt expects 1 argument, got 2"),
        ("atan2(x)", 1, "atan2 expects 2 arguments, got 1"),
        ("min()", 1, "min expects at least 1 argument, got 0"),
        ("ddiff(x,y,z)", 1, "ddiff expects 2 arguments, got 3"),
        ("dbox(x,y,z)", 1, "dbox expects 9 arguments"),
        ("dpoly(x,y,0,0,1,0,1)", 1, "dpoly expects"),
        ("dpoly(x,y,0,0,1,0)", 1, "at least 6 vertex coordinates"),
        ("x y", 3, "unexpected 'y' after a complete expression"),
        ("x + 1 2", 7, "unexpected number 2"),
        ("x,y", 2, "unexpected ','"),
        ("1e", 1, "malformed number '1e'"),
        ("x + 1e+", 5, "malformed number '1e+'"),
        ("..5", 1, "unexpected character '.'"),
        ("2*..5", 3, "unexpected character '.'"),
        ("1.2.3", 1, "malformed number '1.2.3'"),
        ("2x", 1, "malformed number '2x'"),
        ("1 + é", 5, "unexpected character 'é'"),
        ("x # y", 3, "unexpected character '#'"),
        ("2 +", 4, "unexpected end of input"),
        ("3 * )", 5, "unexpected ')'"),
        ("min(x y)", 7, "expected ',' or ')' in the arguments of 'min'"),
        ("max(x,)", 7, "unexpected ')'"),
        ("()", 2, "unexpected ')'"),
    ];
    for &(src, col, msg) in cases {
        let e = err(src);
        assert_eq!(e.column, col, "{src:?}: {e}");
        assert!(e.message.contains(msg), "{src:?}: {e}");
        assert_eq!(e.to_string(), format!("column {col}: {}", e.message));
    }
}

#[test]
fn nesting_and_length_limits() {
    let deep = format!("{}x{}", "(".repeat(300), ")".repeat(300));
    let e = err(&deep);
    assert_eq!(e.column, 257);
    assert!(e.message.contains("nested"), "{e}");
    let ok = format!("{}x{}", "(".repeat(200), ")".repeat(200));
    assert_eq!(ev(&ok, 1.5, 0.0, 0.0), 1.5);
    assert_eq!(err(&format!("{}x", "-".repeat(400))).column, 257);
    assert_eq!(err(&format!("{}x", "sqrt(".repeat(1000))).column, 1281);
    assert_eq!(err(&format!("x{}", "^x".repeat(1000))).column, 2 * 256 + 1);
    // Long but flat input is fine.
    let long = vec!["x*y"; 20000].join("+");
    assert_eq!(ev(&long, 2.0, 3.0, 0.0), 20000.0 * 6.0);
    let long = vec!["x"; 10000].join(",");
    assert_eq!(ev(&format!("max({long})"), 2.0, 3.0, 0.0), 2.0);
    let unfinished = "x+".repeat(50000);
    assert_eq!(err(&unfinished).column, 100001);
}

#[test]
fn render_points_at_column() {
    let src = "dcircle(x, y, 0, 0) + 1";
    let e = err(src);
    assert_eq!(e.render(src), format!("{src}\n^"));
    let src = "x + (y * 2";
    let e = err(src);
    assert_eq!(e.render(src), format!("{src}\n{}^", " ".repeat(10)));
    let src = format!("{}+ sqr(x)", "x + ".repeat(100));
    let e = err(&src);
    let r = e.render(&src);
    let (line, caret) = r.split_once('\n').unwrap();
    let at = caret.len() - 1;
    assert_eq!(&line[at..at + 3], "sqr");
}

#[test]
fn fuzz_entry_handles_junk() {
    for s in [
        &b"\xff\xfe(("[..],
        b"",
        b"min(",
        b"dpoly(x,y,0,0,1,0,1,1,0,1",
        b"1e999*0",
        b"0/0",
        b"ln(-1) + sqrt(-x) + (-8)^(1/3)",
        b"dpoly(x,y,x,y,x,y,x,y)",
        b"atan2(0,0) + 1/0 + pow(0, -1)",
    ] {
        fuzz_parse(s);
    }
    let mut rng = Rng(3);
    let alphabet = b"xyz0123456789.e+-*/^(),  sqrtminaxdpolycrle";
    for _ in 0..3000 {
        let n = (rng.next() * 40.0) as usize;
        let s: Vec<u8> =
            (0..n).map(|_| alphabet[(rng.next() * alphabet.len() as f64) as usize % alphabet.len()]).collect();
        fuzz_parse(&s);
    }
}
