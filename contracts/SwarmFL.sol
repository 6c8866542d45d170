// SPDX-License-Identifier: MIT OR Apache-2.0
pragma solidity 0.8.30;

/// @title swarmfl's federated-learning contract (docs/CONTRACT.md).
/// @notice The same rules as the Rust contract of `core/src/contract/`, integer for integer:
/// staked submissions, outlier rejection by mean absolute distance, FedAvg at the quorum,
/// ranking around the median distance, payouts from the pool with the remainder carried; a
/// bound on claimed samples and a round deadline (beyond the paper: the authors' contract has
/// neither).
/// Tokens are the contract's own ledger (`balances`, in units); the stake a call offers is an
/// explicit argument, so a deployment needs no ether to flow.
/// @dev A call that fails a check returns its outcome code and changes nothing; it never
/// reverts on input, so a chain records why a submission was refused. Options (`flags`) select
/// the authors' variants (geth-argos `federatedsc3V2.sol`) where they differ from swarmfl's.
contract SwarmFL {
    // ----- outcome codes -----------------------------------------------------------------
    uint8 constant ACCEPTED = 0;
    uint8 constant AGGREGATED = 1;
    uint8 constant OUTLIER = 2;
    uint8 constant DUPLICATE = 3;
    uint8 constant INSUFFICIENT_STAKE = 4;
    uint8 constant TRANSFERRED = 5;
    uint8 constant INSUFFICIENT_FUNDS = 6;
    uint8 constant BAD_SENDER = 10; // the sender is not an account
    uint8 constant SAMPLES_ZERO = 11;
    uint8 constant SAMPLES_LIMIT = 12; // a = samples, b = the claim bound
    uint8 constant BAD_LENGTH = 13; // a = length
    uint8 constant WEIGHT_RANGE = 14; // a = index, b = weight (two's complement)
    uint8 constant VALUE_EXCEEDS = 15; // a = value offered
    uint8 constant BAD_ACCOUNTS = 16; // transfer to or from a non-account
    uint8 constant TRANSFER_VALUE = 17; // a = value offered with a transfer
    uint8 constant PRODUCT_RANGE = 18; // a = index: w * n or the running sum leaves int48

    // ----- option flags (0 = swarmfl's rules) --------------------------------------------
    uint256 constant MEDIAN_MEAN = 1; // even count: mean of the two middles, floored
    uint256 constant FEDAVG_TRUNCATE = 2; // FedAvg truncated toward zero
    uint256 constant INT48_PRODUCTS = 4; // refuse when w * n or the round's sum leaves int48
    uint256 constant THRESHOLD_STRICT = 8; // accepted iff distance < threshold * N
    uint256 constant RANK_BY_MAE = 16; // rank by floor(distance / N)
    uint256 constant QUICKSORT_TIES = 32; // ties broken by the authors' quicksort
    uint256 constant PAYOUT_RATIO_1E9 = 64; // shares normalised to 1e9 and floored
    uint256 constant POOL_ROUND_ONLY = 128; // pool = this round's stakes; nothing carried

    int256 constant INT48_MIN = -(2 ** 47);
    int256 constant INT48_MAX = 2 ** 47 - 1;
    uint256 constant MAX_SAMPLES = 2 ** 32 - 1;

    /// One counted submission (accepted or outlier) of the open round.
    struct Submission {
        uint32 sender;
        uint64 samples;
        uint64 distance;
        uint64 stake;
        bool outlier;
    }

    /// Emitted per paid robot at an aggregation, in rank order.
    event Paid(uint32 robot, uint32 rank, int64 rewardWeight, uint64 units);
    /// Emitted when a round closes: the pool distributed and what stayed in the contract.
    event Aggregated(uint64 round, uint64 poolUnits, uint64 carriedUnits);

    address public immutable owner;
    uint32 public immutable robots;
    uint32 public immutable modelLen;

    // Rules (the owner, the chain itself, may change them between rounds).
    uint64 stakeUnits;
    bool security;
    uint32 quorum;
    uint256 maxDistance; // threshold_units * N
    int64[] rewardWeights; // per rank, best first
    uint256 flags;
    uint64 maxSamples; // the claim bound, 1..MAX_SAMPLES
    uint64 roundTimeoutMs; // the round deadline in ms of block time; 0 = none

    mapping(address => uint32) accountPlusOne;
    uint64[] balances;
    uint64 public holdings;
    uint64 public round;

    uint256[] weightsPacked; // four int64 per slot
    uint256[] accPacked; // two int128 per slot: sum n_k w_k of the round's accepted models
    uint256 totalSamples;
    uint32 acceptedCount;
    Submission[] submissions;
    mapping(uint32 => uint64) submittedRoundPlusOne;

    // The round deadline's clock (ms of block time, set by the chain through `enterBlock`).
    uint64 blockTimeMs;
    uint64 roundOpenedMs;
    uint64 roundsTimedOut;
    uint64 timeoutRefundedUnits;

    modifier onlyOwner() {
        require(msg.sender == owner, "owner only");
        _;
    }

    constructor(
        address[] memory accounts,
        uint64 initialUnits,
        int64[] memory genesis,
        uint64 stake,
        bool securityOn,
        uint32 quorumSize,
        uint256 maxDistanceUnits,
        int64[] memory weightsPerRank,
        uint256 optionFlags,
        uint64 claimBound,
        uint64 timeoutMs
    ) {
        require(accounts.length > 0 && accounts.length < 2 ** 32, "accounts");
        require(genesis.length > 0 && genesis.length <= 2 ** 16, "model length");
        owner = msg.sender;
        robots = uint32(accounts.length);
        modelLen = uint32(genesis.length);
        for (uint256 i = 0; i < accounts.length; i++) {
            require(accountPlusOne[accounts[i]] == 0, "duplicate account");
            accountPlusOne[accounts[i]] = uint32(i + 1);
            balances.push(initialUnits);
        }
        uint256 slots = (genesis.length + 3) / 4;
        for (uint256 s = 0; s < slots; s++) {
            uint256 word = 0;
            for (uint256 k = 0; k < 4 && 4 * s + k < genesis.length; k++) {
                int64 w = genesis[4 * s + k];
                require(int256(w) > INT48_MIN && int256(w) <= INT48_MAX, "genesis int48");
                word |= uint256(uint64(w)) << (64 * k);
            }
            weightsPacked.push(word);
        }
        uint256 accSlots = (genesis.length + 1) / 2;
        for (uint256 s = 0; s < accSlots; s++) accPacked.push(0);
        _configure(
            stake, securityOn, quorumSize, maxDistanceUnits, weightsPerRank, optionFlags, claimBound, timeoutMs
        );
    }

    // ----- calls ---------------------------------------------------------------------------

    /// Submits a model `w` (fixed point) trained on `samples`, offering `offered` units as stake.
    function submitModel(int64[] calldata w, uint64 samples, uint64 offered)
        external
        returns (uint8 code, uint64 atRound, uint64 distance, uint256 a, uint256 b)
    {
        uint32 who = accountPlusOne[msg.sender];
        if (who == 0) return (BAD_SENDER, 0, 0, 0, 0);
        uint32 sender = who - 1;
        if (submittedRoundPlusOne[sender] == round + 1) return (DUPLICATE, 0, 0, 0, 0);
        if (samples == 0) return (SAMPLES_ZERO, 0, 0, 0, 0);
        // No robot can collect more than the bound in its data window (docs/CONTRACT.md).
        if (samples > maxSamples) return (SAMPLES_LIMIT, 0, 0, samples, maxSamples);
        uint256 n = w.length;
        if (n != modelLen) return (BAD_LENGTH, 0, 0, n, 0);
        for (uint256 i = 0; i < n; i++) {
            int256 x = w[i];
            if (x <= INT48_MIN || x > INT48_MAX) return (WEIGHT_RANGE, 0, 0, i, uint256(x));
        }
        uint64 stake = 0;
        if (security) {
            if (offered < stakeUnits || balances[sender] < stakeUnits) {
                return (INSUFFICIENT_STAKE, 0, 0, 0, 0);
            }
            if (offered > stakeUnits) return (VALUE_EXCEEDS, 0, 0, offered, 0);
            stake = stakeUnits;
        }

        distance = _distance(w);
        bool outlier = security
            && (flags & THRESHOLD_STRICT != 0 ? distance >= maxDistance : distance > maxDistance);
        bool first = acceptedCount == 0;
        if (!outlier && flags & INT48_PRODUCTS != 0) {
            (bool fits, uint256 at) = _productsFit(w, samples, first);
            if (!fits) return (PRODUCT_RANGE, 0, 0, at, 0);
        }

        balances[sender] -= stake;
        holdings += stake;
        submittedRoundPlusOne[sender] = round + 1;
        submissions.push(Submission(sender, samples, distance, stake, outlier));
        atRound = round;
        if (outlier) return (OUTLIER, atRound, distance, 0, 0);

        _accumulate(w, samples, first);
        totalSamples += samples;
        acceptedCount += 1;
        if (acceptedCount < quorum) return (ACCEPTED, atRound, distance, 0, 0);
        _aggregate();
        return (AGGREGATED, atRound, distance, 0, 0);
    }

    /// Moves `amount` units from the sender to `to`; `offered` must be 0.
    function transfer(address to, uint64 amount, uint64 offered)
        external
        returns (uint8 code, uint64 atRound, uint64 distance, uint256 a, uint256 b)
    {
        uint32 from = accountPlusOne[msg.sender];
        uint32 dest = accountPlusOne[to];
        if (from == 0 || dest == 0) return (BAD_ACCOUNTS, 0, 0, 0, 0);
        if (offered != 0) return (TRANSFER_VALUE, 0, 0, offered, 0);
        if (balances[from - 1] < amount) return (INSUFFICIENT_FUNDS, 0, 0, 0, 0);
        balances[from - 1] -= amount;
        balances[dest - 1] += amount;
        return (TRANSFERRED, 0, 0, 0, 0);
    }

    /// Rules activation: every counted submission of the open round gets its stake back and
    /// may submit again; round, model and carried remainder stay.
    function restartRound() external onlyOwner {
        for (uint256 i = 0; i < submissions.length; i++) {
            Submission memory s = submissions[i];
            holdings -= s.stake;
            balances[s.sender] += s.stake;
            submittedRoundPlusOne[s.sender] = 0;
        }
        delete submissions;
        acceptedCount = 0;
        totalSamples = 0;
    }

    /// Enters a block with timestamp `timestampMs` (the chain calls it before the block's
    /// transactions): records the block time and, when the open round is `roundTimeoutMs` old,
    /// closes it without aggregation. The accepted submissions get their stakes back, the
    /// outliers' stay in the pool, everyone may submit again; round and model stay.
    function enterBlock(uint64 timestampMs) external onlyOwner {
        blockTimeMs = timestampMs;
        if (roundTimeoutMs == 0 || uint256(timestampMs) < uint256(roundOpenedMs) + roundTimeoutMs) return;
        roundOpenedMs = timestampMs;
        if (submissions.length == 0) return; // nothing to refund: the round opens again
        for (uint256 i = 0; i < submissions.length; i++) {
            Submission memory s = submissions[i];
            submittedRoundPlusOne[s.sender] = 0;
            if (s.outlier) continue;
            holdings -= s.stake;
            balances[s.sender] += s.stake;
            timeoutRefundedUnits += s.stake;
        }
        delete submissions;
        acceptedCount = 0;
        totalSamples = 0;
        roundsTimedOut += 1;
    }

    /// Changes the rules (between rounds: call `restartRound` first when a round is open).
    function configure(
        uint64 stake,
        bool securityOn,
        uint32 quorumSize,
        uint256 maxDistanceUnits,
        int64[] calldata weightsPerRank,
        uint256 optionFlags,
        uint64 claimBound,
        uint64 timeoutMs
    ) external onlyOwner {
        require(submissions.length == 0, "restart the open round first");
        _configure(
            stake, securityOn, quorumSize, maxDistanceUnits, weightsPerRank, optionFlags, claimBound, timeoutMs
        );
    }

    // ----- views ---------------------------------------------------------------------------

    /// Every balance, the contract's holdings and the round.
    function state() external view returns (uint64[] memory, uint64, uint64) {
        return (balances, holdings, round);
    }

    /// The shared model, fixed point.
    function getModel() external view returns (int64[] memory w, uint64 version) {
        w = new int64[](modelLen);
        for (uint256 i = 0; i < modelLen; i++) {
            w[i] = int64(uint64(weightsPacked[i / 4] >> (64 * (i % 4))));
        }
        version = round;
    }

    /// The round deadline's clock: the last block time, when the open round opened, the
    /// rounds closed by the deadline and the stake units they refunded.
    function deadline() external view returns (uint64, uint64, uint64, uint64) {
        return (blockTimeMs, roundOpenedMs, roundsTimedOut, timeoutRefundedUnits);
    }

    /// The open round's counted submissions, in submission order.
    function getSubmissions() external view returns (Submission[] memory) {
        return submissions;
    }

    // ----- internals -----------------------------------------------------------------------

    function _configure(
        uint64 stake,
        bool securityOn,
        uint32 quorumSize,
        uint256 maxDistanceUnits,
        int64[] memory weightsPerRank,
        uint256 optionFlags,
        uint64 claimBound,
        uint64 timeoutMs
    ) internal {
        require(quorumSize >= 1 && quorumSize <= robots, "quorum");
        require(claimBound >= 1 && claimBound <= MAX_SAMPLES, "claim bound");
        require(weightsPerRank.length == quorumSize, "one reward weight per rank");
        bool rewarded = false;
        for (uint256 r = 0; r < weightsPerRank.length; r++) {
            if (weightsPerRank[r] > 0) rewarded = true;
        }
        require(rewarded, "at least one rewarded rank");
        stakeUnits = stake;
        security = securityOn;
        quorum = quorumSize;
        maxDistance = maxDistanceUnits;
        rewardWeights = weightsPerRank;
        flags = optionFlags;
        maxSamples = claimBound;
        roundTimeoutMs = timeoutMs;
    }

    /// sum_i |w_i - w_a,i|: below 2^64 (|w| < 2^47, at most 2^16 weights).
    function _distance(int64[] calldata w) internal view returns (uint64) {
        uint256 sum = 0;
        uint256 n = w.length;
        uint256 word;
        for (uint256 i = 0; i < n; i++) {
            uint256 k = i % 4;
            if (k == 0) word = weightsPacked[i / 4];
            int256 d = int256(w[i]) - int256(int64(uint64(word >> (64 * k))));
            sum += uint256(d >= 0 ? d : -d);
        }
        return uint64(sum);
    }

    /// The authors' int48 bound: every w_i * n, and the round's running sum with it, in int48.
    function _productsFit(int64[] calldata w, uint64 samples, bool first)
        internal
        view
        returns (bool, uint256)
    {
        uint256 n = w.length;
        uint256 word;
        for (uint256 i = 0; i < n; i++) {
            int256 p = int256(w[i]) * int256(uint256(samples));
            if (p < INT48_MIN || p > INT48_MAX) return (false, i);
            if (!first) {
                if (i % 2 == 0) word = accPacked[i / 2];
                int256 s = int256(int128(uint128(word >> (128 * (i % 2))))) + p;
                if (s < INT48_MIN || s > INT48_MAX) return (false, i);
            }
        }
        return (true, 0);
    }

    /// acc += n * w (the round's first accepted model overwrites what the last round left).
    function _accumulate(int64[] calldata w, uint64 samples, bool first) internal {
        uint256 n = w.length;
        int256 ns = int256(uint256(samples));
        for (uint256 s = 0; 2 * s < n; s++) {
            uint256 word = first ? 0 : accPacked[s];
            uint256 out = 0;
            for (uint256 k = 0; k < 2 && 2 * s + k < n; k++) {
                int256 v = int256(int128(uint128(word >> (128 * k)))) + int256(w[2 * s + k]) * ns;
                out |= uint256(uint128(int128(v))) << (128 * k);
            }
            accPacked[s] = out;
        }
    }

    /// Closes the round: FedAvg, ranking, payouts, round += 1.
    function _aggregate() internal {
        uint256 n = modelLen;
        int256 den = int256(totalSamples);
        bool truncate = flags & FEDAVG_TRUNCATE != 0;
        for (uint256 s = 0; 4 * s < n; s++) {
            uint256 out = 0;
            for (uint256 k = 0; k < 4 && 4 * s + k < n; k++) {
                uint256 i = 4 * s + k;
                int256 num = int256(int128(uint128(accPacked[i / 2] >> (128 * (i % 2)))));
                int256 v;
                if (truncate) {
                    v = num / den;
                } else {
                    uint256 mag = (uint256(num >= 0 ? num : -num) + uint256(den) / 2) / uint256(den);
                    v = num >= 0 ? int256(mag) : -int256(mag);
                }
                out |= uint256(uint64(int64(v))) << (64 * k);
            }
            weightsPacked[s] = out;
        }

        uint256 pool = holdings;
        uint256 paid = 0;
        if (security) {
            if (flags & POOL_ROUND_ONLY != 0) {
                pool = 0;
                for (uint256 i = 0; i < submissions.length; i++) pool += submissions[i].stake;
            }
            paid = _payout(pool);
        }
        holdings -= uint64(paid);
        emit Aggregated(round, uint64(pool), holdings);
        // The senders' duplicate marks name this round: the next round needs no reset.
        delete submissions;
        acceptedCount = 0;
        totalSamples = 0;
        round += 1;
        roundOpenedMs = blockTimeMs;
    }

    /// Ranks the accepted models and pays them from `pool`; returns the units paid.
    function _payout(uint256 pool) internal returns (uint256 paid) {
        uint256 q = quorum;
        uint32[] memory sender = new uint32[](q);
        uint256[] memory samples = new uint256[](q);
        uint256[] memory key = new uint256[](q);
        uint256 a = 0;
        bool byMae = flags & RANK_BY_MAE != 0;
        for (uint256 i = 0; i < submissions.length; i++) {
            Submission memory s = submissions[i];
            if (s.outlier) continue;
            sender[a] = s.sender;
            samples[a] = s.samples;
            key[a] = byMae ? s.distance / modelLen : s.distance;
            a++;
        }
        uint256[] memory order = _rank(key);

        uint256 base = pool / q;
        uint256 sumRewarded = 0;
        uint256 sumPenalised = 0;
        for (uint256 r = 0; r < q; r++) {
            int256 k = rewardWeights[r];
            uint256 ks = uint256(k >= 0 ? k : -k) * samples[order[r]];
            if (k > 0) sumRewarded += ks;
            if (k < 0) sumPenalised += ks;
        }
        bool ratio = flags & PAYOUT_RATIO_1E9 != 0;
        for (uint256 r = 0; r < q; r++) {
            int256 k = rewardWeights[r];
            uint256 ks = uint256(k >= 0 ? k : -k) * samples[order[r]];
            uint256 units = base;
            if (k > 0 && sumPenalised > 0) {
                units += ratio ? (stakeUnits * ((ks * 1e9) / sumRewarded)) / 1e9 : (ks * stakeUnits) / sumRewarded;
            } else if (k < 0) {
                uint256 penalty = ratio
                    ? (stakeUnits * ((ks * 1e9) / sumPenalised)) / 1e9
                    : (ks * stakeUnits + sumPenalised - 1) / sumPenalised;
                units = penalty >= base ? 0 : base - penalty;
            }
            // Rounded-down penalties (ratio_1e9) can ask for a few units more than the pool:
            // they come from what the contract holds, and run out in rank order.
            if (units > holdings - paid) units = holdings - paid;
            uint32 robot = sender[order[r]];
            balances[robot] += uint64(units);
            paid += units;
            emit Paid(robot, uint32(r), int64(k), uint64(units));
        }
    }

    /// Indices of `key` (submission order), best first: by |key - median|.
    function _rank(uint256[] memory key) internal view returns (uint256[] memory order) {
        uint256 q = key.length;
        uint256[] memory sorted = new uint256[](q);
        for (uint256 i = 0; i < q; i++) sorted[i] = key[i];
        _insertionSort(sorted, new uint256[](q));
        uint256 med = flags & MEDIAN_MEAN != 0
            ? (sorted[q - 1 - q / 2] + sorted[q / 2]) / 2
            : sorted[(q - 1) / 2];
        uint256[] memory dev = new uint256[](q);
        order = new uint256[](q);
        for (uint256 i = 0; i < q; i++) {
            dev[i] = key[i] >= med ? key[i] - med : med - key[i];
            order[i] = i;
        }
        if (flags & QUICKSORT_TIES != 0) {
            _quickSort(dev, order, 0, int256(q) - 1);
        } else {
            _insertionSort(dev, order);
        }
    }

    /// Stable sort of `key` ascending, carrying `idx` along.
    function _insertionSort(uint256[] memory key, uint256[] memory idx) internal pure {
        for (uint256 i = 1; i < key.length; i++) {
            uint256 kv = key[i];
            uint256 iv = idx[i];
            uint256 j = i;
            while (j > 0 && key[j - 1] > kv) {
                key[j] = key[j - 1];
                idx[j] = idx[j - 1];
                j--;
            }
            key[j] = kv;
            idx[j] = iv;
        }
    }

    /// The authors' Hoare quicksort (not stable), carrying `idx` along.
    function _quickSort(uint256[] memory key, uint256[] memory idx, int256 left, int256 right) internal pure {
        int256 i = left;
        int256 j = right;
        if (i == j) return;
        uint256 pivot = key[uint256(left + (right - left) / 2)];
        while (i <= j) {
            while (key[uint256(i)] < pivot) i++;
            while (pivot < key[uint256(j)]) j--;
            if (i <= j) {
                (key[uint256(i)], key[uint256(j)]) = (key[uint256(j)], key[uint256(i)]);
                (idx[uint256(i)], idx[uint256(j)]) = (idx[uint256(j)], idx[uint256(i)]);
                i++;
                j--;
            }
        }
        if (left < j) _quickSort(key, idx, left, j);
        if (i < right) _quickSort(key, idx, i, right);
    }
}
