//! `X,Y,Z` command-line vectors.

use glam::Vec3;

/// Parses `X,Y,Z` into a finite vector; clap shows the message on failure.
pub fn parse(text: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else {
        return Err(format!("expected X,Y,Z (three numbers), got `{text}`"));
    };
    let number = |s: &str| {
        s.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{s}` is not a finite number"))
    };
    Ok(Vec3::new(number(x)?, number(y)?, number(z)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_three_numbers() {
        assert_eq!(parse("1, -2.5,3e0"), Ok(Vec3::new(1.0, -2.5, 3.0)));
    }

    #[test]
    fn rejects_wrong_arity_and_non_finite() {
        assert!(parse("1,2").is_err());
        assert!(parse("1,2,3,4").is_err());
        assert!(parse("1,nan,3").is_err());
        assert!(parse("1,inf,3").is_err());
        assert!(parse("1,x,3").is_err());
    }
}
