//! Helpers shared by the unit tests of the file parsers.

/// Applies random edits to `text`: each `(pos, op, pick)` inserts, removes or
/// replaces the character at `pos` (modulo the length) with `alphabet[pick]`, so
/// that property tests explore files that are almost valid.
pub fn mutate(text: &str, edits: &[(usize, u8, usize)], alphabet: &str) -> String {
    let alphabet: Vec<char> = alphabet.chars().collect();
    let mut chars: Vec<char> = text.chars().collect();
    for &(pos, op, pick) in edits {
        let c = alphabet[pick % alphabet.len()];
        let at = if chars.is_empty() {
            0
        } else {
            pos % (chars.len() + 1)
        };
        match op % 3 {
            0 => chars.insert(at, c),
            1 if at < chars.len() => {
                chars.remove(at);
            }
            _ if at < chars.len() => chars[at] = c,
            _ => chars.push(c),
        }
    }
    chars.into_iter().collect()
}
