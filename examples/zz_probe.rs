fn main() {
    for n in [2500usize, 5000, 10000, 25000] {
        let terms: Vec<String> = (0..n)
            .map(|i| format!("{}*sin(x*{}+y)*exp(-((x-{})^2+(y-0.{})^2))", 1.0 + i as f64 * 1e-3, i, i % 7, i % 10))
            .collect();
        let src = terms.join(" + ");
        let t = std::time::Instant::now();
        let e = trussmesh::expr::Expr::parse(&src).unwrap();
        let parse = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let mut s = 0.0;
        for k in 0..100 {
            s += e.eval(k as f64 * 0.01, 0.3, 0.0);
        }
        println!(
            "{n} terms, {} bytes: parse {parse:.3} s, eval {:.2e} s each ({s:.1})",
            src.len(),
            t.elapsed().as_secs_f64() / 100.0
        );
    }
}
