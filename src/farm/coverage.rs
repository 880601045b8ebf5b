//! What a part covers: sample ranges over pixel regions (`brume:coverage`, e.g.
//! `0..64@0,0,320,240`), parsed, printed, checked for overlap and coalesced.
/// Sample indices `[start, end)` of every pixel of `region` (`[x0, y0, x1, y1]`, half-open).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Coverage {
    pub start: u32,
    pub end: u32,
    pub region: [u32; 4],
}

impl Coverage {
    /// Whether the two hold a common (pixel, sample).
    pub fn overlaps(&self, o: &Coverage) -> bool {
        let [ax0, ay0, ax1, ay1] = self.region;
        let [bx0, by0, bx1, by1] = o.region;
        self.start.max(o.start) < self.end.min(o.end)
            && ax0.max(bx0) < ax1.min(bx1)
            && ay0.max(by0) < ay1.min(by1)
    }

    pub(super) fn contains_pixel(&self, x: u32, y: u32) -> bool {
        let [x0, y0, x1, y1] = self.region;
        (x0..x1).contains(&x) && (y0..y1).contains(&y)
    }
}

impl std::fmt::Display for Coverage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x0, y0, x1, y1] = self.region;
        write!(f, "{}..{}@{x0},{y0},{x1},{y1}", self.start, self.end)
    }
}

/// Parses `START..END` (half-open sample indices).
pub fn parse_range(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once("..")
        .ok_or_else(|| format!("sample range {s:?} is not START..END"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|e| format!("sample range {s:?}: {t:?}: {e}"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if a > b {
        return Err(format!("sample range {s:?} ends before it starts"));
    }
    Ok((a, b))
}

/// Parses `x0,y0,x1,y1` (a half-open pixel rectangle).
pub fn parse_region(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("region {s:?} is not x0,y0,x1,y1: {e}"))?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        [_, _, _, _] => Err(format!("region {s:?} is empty (need x0 < x1 and y0 < y1)")),
        _ => Err(format!("region {s:?} is not x0,y0,x1,y1")),
    }
}

pub(super) fn parse_coverage(s: &str) -> Result<Vec<Coverage>, String> {
    if s.is_empty() {
        return Ok(Vec::new());
    }
    s.split(';')
        .map(|item| {
            let (range, region) = item
                .split_once('@')
                .ok_or_else(|| format!("coverage item {item:?} is not START..END@x0,y0,x1,y1"))?;
            let (start, end) = parse_range(range)?;
            // An empty range has an empty region on its side of no consequence.
            let region = parse_region(region)?;
            Ok(Coverage { start, end, region })
        })
        .collect()
}

/// Sorts coverage items and joins neighbours (same region, touching ranges), so that the
/// coverage of a merge of merges stays short.
pub fn coalesce(mut items: Vec<Coverage>) -> Vec<Coverage> {
    items.retain(|c| c.start < c.end);
    items.sort_by_key(|c| (c.region, c.start));
    let mut out: Vec<Coverage> = Vec::with_capacity(items.len());
    for c in items {
        match out.last_mut() {
            Some(l) if l.region == c.region && l.end == c.start => l.end = c.end,
            _ => out.push(c),
        }
    }
    out.sort_by_key(|c| (c.start, c.region));
    out
}

pub(super) fn coverage_text(items: &[Coverage]) -> String {
    items
        .iter()
        .map(Coverage::to_string)
        .collect::<Vec<_>>()
        .join(";")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_regions_and_coverage_parse_and_coalesce() {
        assert_eq!(parse_range("3..9"), Ok((3, 9)));
        assert_eq!(parse_range("4..4"), Ok((4, 4)));
        assert!(parse_range("9..3").is_err());
        assert!(parse_range("3-9").is_err());
        assert_eq!(parse_region("0,1,2,3"), Ok([0, 1, 2, 3]));
        assert!(parse_region("2,1,2,3").is_err());
        let r = [0, 0, 4, 4];
        let c = |start, end| Coverage {
            start,
            end,
            region: r,
        };
        assert_eq!(coalesce(vec![c(4, 8), c(0, 4), c(8, 8)]), vec![c(0, 8)]);
        let items = vec![c(0, 2), c(5, 9)];
        assert_eq!(parse_coverage(&coverage_text(&items)), Ok(items));
        assert!(c(0, 4).overlaps(&c(3, 5)));
        assert!(!c(0, 4).overlaps(&c(4, 5)));
        let other = Coverage {
            start: 0,
            end: 4,
            region: [4, 0, 8, 4],
        };
        assert!(!c(0, 4).overlaps(&other));
    }
}
