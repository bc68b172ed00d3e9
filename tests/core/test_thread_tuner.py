"""ThreadTuner: the torch thread count for Train's steps, chosen by timing them (fake clock and thread setter)."""
import threading

import pytest

from lapig.lapig_core.common.thread_tuner import ThreadTuner


class FakeMachine:
    """A step's seconds by thread count, changed by the test as 'other work' comes and goes."""

    def __init__(self, seconds_at: dict, start: int = 2):
        self.seconds_at, self.threads, self.now, self.sets = dict(seconds_at), start, 0.0, []

    def set_threads(self, n):
        self.threads = n
        self.sets.append(n)

    def tuner(self, **kw):
        return ThreadTuner(set_threads=self.set_threads, get_threads=lambda: self.threads, clock=lambda: self.now, **kw)

    def run(self, tuner, steps: int) -> list[int]:
        counts = []
        for _ in range(steps):
            with tuner.step():
                counts.append(self.threads)  # the count this step runs at
                self.now += self.seconds_at[self.threads]
        return counts


def test_an_idle_machine_keeps_all_its_threads_and_tries_one_ever_more_rarely():
    machine = FakeMachine({2: 0.100, 1: 0.170})
    tuner = machine.tuner()
    counts = machine.run(tuner, 1300)  # a CPU Train's CompenNeSt and PCNet, 1000 + 300
    assert tuner.current == 2 and tuner.switches == 0
    # trials after 4, 50, 100, 200, 400 steps (the next would come 800 later): 5 trials of 3 steps at one thread
    assert tuner.trials == 5 and counts.count(1) == 15
    extra = sum(machine.seconds_at[c] for c in counts) / (1300 * 0.100) - 1
    assert extra < 0.01  # under 1 % of Train for the trials
    assert all(h["kept"] == 2 and h["tried"] == 1 for h in tuner.history)
    tuner.restore()
    assert machine.threads == 2


def test_other_work_on_the_cores_moves_the_steps_to_one_thread_and_back_when_it_ends():
    machine = FakeMachine({2: 0.400, 1: 0.170})  # a second process's Train holds the other core
    tuner = machine.tuner()
    counts = machine.run(tuner, 20)
    assert tuner.current == 1 and tuner.switches == 1
    assert counts[:4] == [2] * 4 and counts[7:] == [1] * 13  # 4 steps, 3 on trial, then one thread
    machine.seconds_at = {2: 0.100, 1: 0.170}  # the other work ended
    counts = machine.run(tuner, 60)
    assert tuner.current == 2 and tuner.switches == 2
    assert counts[-10:] == [2] * 10
    summary = tuner.summary()
    assert summary["start"] == 2 and summary["end"] == 2 and summary["switches"] == 2
    assert set(summary["steps_at"]) == {"1", "2"} and sum(summary["steps_at"].values()) == 80
    assert summary["ms_per_step_at"]["1"] == 170.0


def test_a_second_train_after_a_long_idle_run_is_answered_within_steps_not_hundreds():
    """A Train alone for 1000 steps waits 800 steps between trials; when a second Train starts (both slow to
    0.356 s a step at two threads, 0.145 s at one, as measured on two cores), its step time jumps and the next
    trial comes at once."""
    machine = FakeMachine({2: 0.079, 1: 0.143})
    tuner = machine.tuner()
    machine.run(tuner, 1000)
    trials_alone = tuner.trials
    machine.seconds_at = {2: 0.356, 1: 0.145}
    counts = machine.run(tuner, 20)
    assert tuner.current == 1 and counts[-10:] == [1] * 10
    assert tuner.trials == trials_alone + 1
    # the other Train ended: a step at one thread takes as long as before, so a periodic trial finds it, and on
    # fewer threads than at the start those come at least every 200 steps
    machine.run(tuner, 600)
    machine.seconds_at = {2: 0.079, 1: 0.143}
    counts = machine.run(tuner, 210)
    assert tuner.current == 2 and counts[-5:] == [2] * 5


def test_a_small_difference_is_not_a_reason_to_switch():
    machine = FakeMachine({2: 0.100, 1: 0.095})  # 5 %: inside the wander of step times
    tuner = machine.tuner()
    machine.run(tuner, 300)
    assert tuner.current == 2 and tuner.switches == 0 and tuner.trials >= 3


def test_restore_in_the_middle_of_a_trial_gives_the_starting_count_back():
    machine = FakeMachine({2: 0.100, 1: 0.170})
    tuner = machine.tuner()
    machine.run(tuner, 5)  # the 5th step ran on trial at one thread
    assert tuner.running_count == 1 and machine.threads == 1
    tuner.restore()
    assert machine.threads == 2


def test_many_cores_try_half_first_and_climb_down_only_while_it_pays():
    """Sixteen threads: a trial of one thread would cost 3 steps at a tenth of the speed; half is tried instead."""
    machine = FakeMachine({16: 0.020, 8: 0.030, 4: 0.050, 2: 0.090, 1: 0.170}, start=16)
    tuner = machine.tuner()
    counts = machine.run(tuner, 1300)
    assert tuner.current == 16 and set(counts) == {16, 8}
    machine.seconds_at = {16: 0.120, 8: 0.060, 4: 0.065, 2: 0.100, 1: 0.170}  # a render holds half the cores
    counts = machine.run(tuner, 200)
    assert tuner.current == 8 and counts[-5:] == [8] * 5
    assert set(counts) <= {16, 8, 4}  # from 8: 4 (not faster by 10 %) and 16 tried in turn


def test_one_count_to_choose_from_only_times_the_steps():
    machine = FakeMachine({1: 0.2}, start=1)
    tuner = machine.tuner()
    assert not tuner.active
    machine.run(tuner, 100)
    tuner.restore()
    assert machine.sets == [] and tuner.summary()["steps_at"] == {"1": 100}


@pytest.mark.torch
def test_the_count_set_on_a_worker_thread_is_that_threads_alone():
    """torch under OpenMP: a worker's set_num_threads does not change the main thread's count (the add-on's
    Train runs on a worker beside Blender's main thread)."""
    torch = pytest.importorskip("torch")
    if torch.get_num_threads() < 2:
        pytest.skip("one CPU thread: nothing to choose between")
    before = torch.get_num_threads()
    seen = {}

    def worker():
        tuner = ThreadTuner()
        torch.set_num_threads(1)
        seen["worker"] = torch.get_num_threads()
        tuner.restore()
        seen["after"] = torch.get_num_threads()

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join()
    assert seen == {"worker": 1, "after": before}
    assert torch.get_num_threads() == before


@pytest.mark.torch
def test_bench_threads_runs_train_beside_a_second_train_and_counts_its_steps():
    """The benchmark's parts on the device check's fixture: Train's iterations on a worker, a second Train in its
    own process counted through its file, the tuner's summary kept."""
    from lapig.tools.bench import bench_threads
    from lapig.tools.bench.device_fixture import FIXTURE

    make = bench_threads.trainer_factory(str(FIXTURE / "setups" / "device_check"))
    made = []

    def trainer_of(tuned):
        made.append(make(tuned, 8))
        return made[-1]

    idle = bench_threads.run_train(trainer_of, 6, tuned=False)
    beside = bench_threads.run_train(trainer_of, 6, tuned=True, beside="train",
                                     capture=str(FIXTURE / "setups" / "device_check"))
    assert idle["s_per_iteration"] > 0 and "other_steps_per_s" not in idle
    assert beside["other_steps_per_s"] > 0
    assert made[0].result.threads is None and sum(made[1].result.threads["steps_at"].values()) == 7
    figures = bench_threads._compare({"fixed": [idle], "tuned": [idle]}, [made[1].result.threads])
    assert figures["tuned_over_fixed"] == 1.0 and figures["tuner"] == [made[1].result.threads]
