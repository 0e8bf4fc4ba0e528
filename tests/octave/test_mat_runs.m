% tests/octave/test_mat_runs.m -- runs saved by Octave itself (its own MAT writer, v7 and v6,
% variables and a struct) read by `indicial predict` exactly as the CSV of the same numbers.
%
%   octave-cli --norc -q tests/octave/test_mat_runs.m INDICIAL_EXE SOURCE_DIR WORK_DIR
% Exits 1 if any check fails (ctest test `mat_octave`).
1;

function out = numbers(path)
  % The predict CSV without its comment lines (they name the input file).
  text = fileread(path);
  lines = strsplit(text, "\n");
  keep = cellfun(@(l) isempty(l) || l(1) ~= '#', lines);
  out = strjoin(lines(keep), "\n");
end

args = argv();
exe = args{1};
model = fullfile(args{2}, 'examples', 'synthetic-lift-moment.coef');
work = args{3};
if ~exist(work, 'dir'), mkdir(work); end
failed = 0;

time_s = (0:199)' * 0.01;
alpha_deg = 10 + 8 * sin(2 * pi * 1.1 * time_s);
q_degps = 8 * 2 * pi * 1.1 * cos(2 * pi * 1.1 * time_s);
Cm = 0.01 * sin(2 * pi * 1.1 * time_s - 0.3);
description = 'Octave-written run';   % a char variable: ignored with a note
f = fopen(fullfile(work, 'run.csv'), 'w');
fprintf(f, 'time_s,alpha_deg,q_degps,Cm\n');
fprintf(f, '%.17g,%.17g,%.17g,%.17g\n', [time_s alpha_deg q_degps Cm]');
fclose(f);
save('-v7', fullfile(work, 'run-v7.mat'), 'time_s', 'alpha_deg', 'q_degps', 'Cm', 'description');
save('-v6', fullfile(work, 'run-v6.mat'), 'time_s', 'alpha_deg', 'q_degps', 'Cm');
run.time_s = time_s'; run.alpha_deg = alpha_deg; run.q_degps = q_degps; run.Cm = Cm;
save('-v7', fullfile(work, 'run-struct.mat'), 'run');

predict = @(in, out) system(sprintf('"%s" predict "%s" "%s" --out "%s" --force 2>&1', exe, model, in, out));
[rc, msg] = predict(fullfile(work, 'run.csv'), fullfile(work, 'from-csv.csv'));
if rc ~= 0, failed = failed + 1; fprintf(2, 'FAILED: predict on the CSV: %s\n', msg); end
reference = numbers(fullfile(work, 'from-csv.csv'));
for name = {'run-v7.mat', 'run-v6.mat', 'run-struct.mat'}
  out = fullfile(work, ['from-' name{1} '.csv']);
  [rc, msg] = predict(fullfile(work, name{1}), out);
  if rc ~= 0
    failed = failed + 1;
    fprintf(2, 'FAILED: predict on %s: %s\n', name{1}, msg);
  elseif ~strcmp(numbers(out), reference) || numel(reference) < 1000
    failed = failed + 1;
    fprintf(2, 'FAILED: predict on %s differs from predict on the CSV\n', name{1});
  end
end
% A mistyped variable: the angle as text.
alpha_deg = 'ten degrees';
save('-v7', fullfile(work, 'bad.mat'), 'time_s', 'alpha_deg', 'Cm');
[rc, msg] = predict(fullfile(work, 'bad.mat'), fullfile(work, 'bad.csv'));
if rc ~= 1 || isempty(strfind(msg, 'variable alpha_deg (1x11) is a char array'))
  failed = failed + 1;
  fprintf(2, 'FAILED: a char angle must be refused naming it, got %d: %s\n', rc, msg);
end
if failed > 0, exit(1); end
printf('test_mat_runs: all checks passed\n');
exit(0);
