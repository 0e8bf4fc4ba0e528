% tests/octave/test_mex.m -- the MEX stepper (runtime/src/mex/indicial_mex.cpp) under Octave:
% one instance and a batch compared with `indicial predict` on the same motion, then every kind
% of bad call, each of which must raise a clear error (identifier indicial:*) and never crash.
%
%   octave-cli --norc -q tests/octave/test_mex.m MEX_DIR INDICIAL_EXE SOURCE_DIR WORK_DIR
% Exits 1 if any check fails (ctest test `mex_octave`).
1;  % a script file, not a function file

function check(cond, what)
  global n_failed;
  if ~cond
    n_failed = n_failed + 1;
    fprintf(2, 'FAILED: %s\n', what);
  end
end

% Runs fn (a function handle) and checks that it raises an error with this identifier whose
% message contains the text.
function expect_error(fn, id, text)
  global n_failed;
  try
    fn();
    n_failed = n_failed + 1;
    fprintf(2, 'FAILED: no error (expected %s: %s)\n', id, text);
  catch e
    ok = strcmp(e.identifier, id) && ~isempty(strfind(e.message, text));
    if ~ok
      n_failed = n_failed + 1;
      fprintf(2, 'FAILED: expected %s "%s", got %s "%s"\n', id, text, e.identifier, e.message);
    end
  end
end

% The numeric rows of a CSV with '#' comment lines and one header row.
function [header, data] = read_csv(path)
  f = fopen(path, 'r');
  header = {};
  rows = {};
  while true
    line = fgetl(f);
    if ~ischar(line), break; end
    if isempty(line) || line(1) == '#', continue; end
    if isempty(header)
      header = strsplit(line, ',');
    else
      rows{end + 1} = str2double(strsplit(line, ','));
    end
  end
  fclose(f);
  data = vertcat(rows{:});
end

global n_failed;
n_failed = 0;
args = argv();
addpath(args{1});
exe = args{2};
model = fullfile(args{3}, 'examples', 'synthetic-lift-moment.coef');
work = args{4};
if ~exist(work, 'dir'), mkdir(work); end

% ---- a pitch motion with a jittered time grid, and `indicial predict` on it ----------------
n = 300;
t = zeros(n, 1);
for i = 2:n
  t(i) = t(i - 1) + 0.004 + 0.0015 * sin(0.7 * i)^2;
end
w = 2 * pi * 1.3;
alpha = 0.35 + 0.38 * sin(w * t);
q = 0.38 * w * cos(w * t);
V = 25;
csv = fullfile(work, 'motion.csv');
f = fopen(csv, 'w');
fprintf(f, 'time_s,alpha_rad,q_radps\n');
fprintf(f, '%.17g,%.17g,%.17g\n', [t alpha q]');
fclose(f);
predicted_csv = fullfile(work, 'predicted.csv');
[rc, out] = system(sprintf('"%s" predict "%s" "%s" --out "%s" --time-grid nonuniform --airspeed-mps %g --force', ...
                           exe, model, csv, predicted_csv, V));
check(rc == 0, ['indicial predict: ' out]);
[header, p] = read_csv(predicted_csv);
cl_pred = p(:, strcmp(header, 'CL_pred'));
cm_pred = p(:, strcmp(header, 'Cm_pred'));

% ---- one instance ----------------------------------------------------------------------------
h = indicial_mex('load', model);
names = indicial_mex('outputs', h);
check(isequal(names, {'CL', 'Cm'}), 'outputs are CL, Cm');
check(abs(indicial_mex('airspeed', h) - 17.667762) < 1e-12, 'reference airspeed');
C = zeros(n, 2);
status = zeros(n, 1);
status(1) = indicial_mex('reset', h, alpha(1), V);
C(1, :) = indicial_mex('evaluate', h, q(1), V);
for i = 2:n
  [C(i, :), status(i)] = indicial_mex('step', h, alpha(i), q(i), V, t(i) - t(i - 1));
end
err_single = max(max(abs(C - [cl_pred cm_pred])));
printf('one instance: largest |MEX - predict| = %g over %d samples (%d clamped)\n', err_single, n, sum(status == 1));
check(err_single <= 1e-12, 'one instance matches indicial predict to 1e-12');
check(any(status == 1), 'the motion leaves the envelope: status 1 at some samples');

% ---- a batch of 3 instances: different motions, the same dt ------------------------------------
b = indicial_mex('load', model, 3);
gain = [1.0; 0.5; 1.2];
ab = 0.35 + gain * 0.38 * sin(w * t');   % 3 x n
qb = gain * 0.38 * w * cos(w * t');
Cb = zeros(3, 2, n);
indicial_mex('reset', b, ab(:, 1), V);
Cb(:, :, 1) = indicial_mex('evaluate', b, qb(:, 1), V);
for i = 2:n
  Cb(:, :, i) = indicial_mex('step', b, ab(:, i), qb(:, i), V, t(i) - t(i - 1));
end
% Each instance against its own single-instance run.
err_batch = 0;
for k = 1:3
  s = indicial_mex('load', model);
  indicial_mex('reset', s, ab(k, 1), V);
  Ck = zeros(n, 2);
  Ck(1, :) = indicial_mex('evaluate', s, qb(k, 1), V);
  for i = 2:n
    Ck(i, :) = indicial_mex('step', s, ab(k, i), qb(k, i), V, t(i) - t(i - 1));
  end
  err_batch = max(err_batch, max(max(abs(Ck - squeeze(Cb(k, :, :))'))));
  indicial_mex('free', s);
end
printf('batch of 3: largest |batch - single| = %g\n', err_batch);
check(err_batch <= 1e-12, 'the batch matches single instances to 1e-12');
check(max(max(abs(squeeze(Cb(1, :, :))' - C))) <= 1e-12, 'batch instance 1 is the predicted motion');

% ---- bad calls: a clear error each, state unchanged -------------------------------------------
before = indicial_mex('evaluate', h, 0, V);
expect_error(@() indicial_mex(), 'indicial:usage', 'first argument is a command');
expect_error(@() indicial_mex(42), 'indicial:usage', 'first argument is a command');
expect_error(@() indicial_mex('jump', h), 'indicial:usage', 'unknown command');
expect_error(@() indicial_mex('step', h, 0.1, 0, V), 'indicial:usage', 'usage');
expect_error(@() indicial_mex('step', h, 'a', 0, V, 0.01), 'indicial:badArgument', 'angle_rad must be real double');
expect_error(@() indicial_mex('step', h, 0.1 + 2i, 0, V, 0.01), 'indicial:badArgument', 'angle_rad');
expect_error(@() indicial_mex('step', h, int32(1), 0, V, 0.01), 'indicial:badArgument', 'angle_rad');
expect_error(@() indicial_mex('step', h, sparse(0.1), 0, V, 0.01), 'indicial:badArgument', 'angle_rad');
expect_error(@() indicial_mex('step', h, {0.1}, 0, V, 0.01), 'indicial:badArgument', 'angle_rad');
expect_error(@() indicial_mex('step', h, [0.1 0.2], 0, V, 0.01), 'indicial:badSize', 'expected 1 (one instance)');
expect_error(@() indicial_mex('step', h, 0.1, 0, V, [0.01 0.02]), 'indicial:badArgument', 'dt_s must be a real double scalar');
expect_error(@() indicial_mex('step', h, NaN, 0, V, 0.01), 'indicial:step', 'NaN or Inf');
expect_error(@() indicial_mex('step', h, 0.1, 0, V, 0), 'indicial:step', 'non_positive_dt');
expect_error(@() indicial_mex('step', h, 0.1, 0, V, 2), 'indicial:step', 'dt_too_large');
expect_error(@() indicial_mex('step', h, 0.1, 0, -1, 0.01), 'indicial:step', 'non_positive_airspeed');
expect_error(@() indicial_mex('reset', h, 0.1, 0), 'indicial:reset', 'airspeed > 0');
expect_error(@() indicial_mex('step', b, [0.1; 0.2], 0, V, 0.01), 'indicial:badSize', 'expected 1 or 3');
expect_error(@() indicial_mex('step', b, [0.1; NaN; 0.2], 0, V, 0.01), 'indicial:step', 'instance 2');
% A batch step refused in one lane steps no instance (all or nothing).
before_b = indicial_mex('evaluate', b, 0, V);
expect_error(@() indicial_mex('step', b, 0.5, 0, [V; -1; V], 0.01), 'indicial:step', 'non_positive_airspeed');
expect_error(@() indicial_mex('step', b, 0.5, [0; 1e300; 0], [V; 1e-300; V], 0.01), 'indicial:step', 'non_finite_result');
check(isequal(indicial_mex('evaluate', b, 0, V), before_b), 'a refused batch step changed no instance');
expect_error(@() indicial_mex('step', 99, 0.1, 0, V, 0.01), 'indicial:badHandle', 'not a handle');
expect_error(@() indicial_mex('step', 1.5, 0.1, 0, V, 0.01), 'indicial:badHandle', 'not a handle');
expect_error(@() indicial_mex('step', 'h', 0.1, 0, V, 0.01), 'indicial:badArgument', 'the handle');
check(isequal(indicial_mex('evaluate', h, 0, V), before), 'refused calls changed nothing');
expect_error(@() indicial_mex('load', 3), 'indicial:badArgument', 'FILE must be a char');
expect_error(@() indicial_mex('load', fullfile(work, 'no-such.coef')), 'indicial:load', 'cannot read');
expect_error(@() indicial_mex('load', '/dev/zero'), 'indicial:load', 'larger than 1 MB');
expect_error(@() indicial_mex('load', model, 0), 'indicial:badArgument', 'N must be');
expect_error(@() indicial_mex('load', model, 2.5), 'indicial:badArgument', 'N must be');
damaged = fullfile(work, 'damaged.coef');
f = fopen(damaged, 'w');
fprintf(f, 'indicial-coef 1\naxis pitch\nreference_length_m -1\n');
fclose(f);
expect_error(@() indicial_mex('load', damaged), 'indicial:load', 'damaged.coef: line');
fresh = indicial_mex('load', model);
expect_error(@() indicial_mex('step', fresh, 0.1, 0, V, 0.01), 'indicial:step', 'not_reset');
expect_error(@() indicial_mex('evaluate', fresh, 0, V), 'indicial:evaluate', 'not_reset');
indicial_mex('free', fresh);
expect_error(@() indicial_mex('outputs', fresh), 'indicial:badHandle', 'not a handle');
expect_error(@() indicial_mex('free', fresh), 'indicial:badHandle', 'not a handle');
indicial_mex('free', h);
indicial_mex('free', b);
clear indicial_mex;  % frees whatever is left (mexAtExit)

if n_failed > 0
  fprintf(2, '%d check(s) failed\n', n_failed);
  exit(1);
end
printf('test_mex: all checks passed\n');
exit(0);
