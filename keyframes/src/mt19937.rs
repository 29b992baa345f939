//! numpy's legacy random stream (`np.random.seed(s)` then `np.random.rand`): MT19937 seeded with
//! `init_genrand(s)`, doubles from two 32-bit outputs as (a≫5, b≫6) → (a·2²⁶ + b)/2⁵³. NMFD's random
//! templates (libnmfd seeds 42) come from it, so our activations can equal libnmfd's.

pub struct Mt19937 {
    state: [u32; 624],
    index: usize,
}

impl Mt19937 {
    /// `init_genrand(seed)`.
    pub fn new(seed: u32) -> Mt19937 {
        let mut state = [0u32; 624];
        state[0] = seed;
        for i in 1..624 {
            let prev = state[i - 1];
            state[i] = 1_812_433_253u32
                .wrapping_mul(prev ^ (prev >> 30))
                .wrapping_add(i as u32);
        }
        Mt19937 { state, index: 624 }
    }

    fn twist(&mut self) {
        for i in 0..624 {
            let y = (self.state[i] & 0x8000_0000) | (self.state[(i + 1) % 624] & 0x7fff_ffff);
            let mut v = self.state[(i + 397) % 624] ^ (y >> 1);
            if y & 1 == 1 {
                v ^= 0x9908_b0df;
            }
            self.state[i] = v;
        }
        self.index = 0;
    }

    pub fn next_u32(&mut self) -> u32 {
        if self.index >= 624 {
            self.twist();
        }
        let mut y = self.state[self.index];
        self.index += 1;
        y ^= y >> 11;
        y ^= (y << 7) & 0x9d2c_5680;
        y ^= (y << 15) & 0xefc6_0000;
        y ^= y >> 18;
        y
    }

    /// A double in [0, 1) with 53 random bits (numpy `random_sample`).
    pub fn next_f64(&mut self) -> f64 {
        let a = (self.next_u32() >> 5) as f64;
        let b = (self.next_u32() >> 6) as f64;
        (a * 67_108_864.0 + b) / 9_007_199_254_740_992.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equals_numpy_seed_42() {
        // np.random.seed(42); np.random.rand(3)
        let mut r = Mt19937::new(42);
        assert_eq!(r.next_f64(), 0.3745401188473625);
        assert_eq!(r.next_f64(), 0.9507143064099162);
        assert_eq!(r.next_f64(), 0.7319939418114051);
        // The reference MT19937 (seed 5489) first output.
        assert_eq!(Mt19937::new(5489).next_u32(), 3_499_211_612);
    }
}
